"""The world's cue and sensors at tracked poses: what a driver publishes for real robots.

:class:`TrackedWorld` is a :class:`~swarm_world.world.World` whose robots are not simulated:
their poses come from an overhead tracker (:meth:`TrackedWorld.track`) and their IR from the
robots' telemetry (:meth:`TrackedWorld.set_ir`). Everything else is the world's own code: the
ground readings are ``World.ground`` at the tracked poses, a step cleans the cue there on each
cleaning tick (eq. 3, ``CueField.clean_at``) and runs its transport, so the cleaning record a
bag keeps rebuilds the cue exactly as it does for a simulated episode (the ARK idea: the cue
is virtual, the robots real). Pure (no ROS).
"""

from __future__ import annotations

import numpy as np

from mona_controller.mona import MonaParams
from swarm_world.driver.calibration import ADC_MAX, IrCalibration
from swarm_world.params import WorldParams
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World


class TrackedWorld(World):
    """N real Monas on the virtual cue field: tracked poses, telemetry IR, the world's cue.

    Args:
        params: the world section (arena, cue, cleaning).
        mona: the robots' geometry and IR ring.
        sensing: the virtual ground sensors' model (the real IR sensors perceive).
        calibration: raw IR ADC to range.
        robot_margin: how far (m) beyond a body edge the point a beam reports may lie and
            still be that robot (the tracker's error).
    """

    def __init__(self, params: WorldParams, mona: MonaParams, sensing: SensingParams,
                 calibration: IrCalibration | None = None, robot_margin: float = 0.02) -> None:
        super().__init__(params, mona, sensing)
        self.calibration = calibration or IrCalibration()
        self.robot_margin = robot_margin
        self.tracked = np.zeros((0, 3))
        self.raw_ir = np.zeros((0, mona.ir_count), dtype=np.int64)
        self.held = np.zeros(0, dtype=bool)  #: robots the driver holds still (faults)
        self.commanded = (np.zeros(0), np.zeros(0))  #: the last step's (linear, angular)

    @property
    def poses(self) -> np.ndarray:
        """[N, 3] the latest tracked poses (x m, y m, heading rad), world frame."""
        return self.tracked

    @property
    def population(self) -> int:
        """The number of robots in the current episode."""
        return len(self.tracked)

    def reset(self, poses: np.ndarray, seed: int = 0) -> None:
        """Start an episode; the robots are taken to be at ``poses`` (the announced ones)
        until the tracker says otherwise, and to see nothing until their telemetry comes."""
        super().reset(poses, seed)
        n = self.physics.count
        self.tracked = np.asarray(poses, dtype=np.float64).reshape(-1, 3).copy()
        self.raw_ir = np.full((n, self.mona.ir_count), ADC_MAX, dtype=np.int64)
        self.held = np.zeros(n, dtype=bool)
        self.commanded = (np.zeros(n), np.zeros(n))

    def track(self, poses: np.ndarray) -> np.ndarray:
        """Take the tracker's poses [N, 3]; a row with a NaN (a dropout) keeps the robot's
        last pose. Returns which rows were valid."""
        poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)[:self.population]
        valid = np.zeros(self.population, dtype=np.bool_)
        valid[:len(poses)] = np.isfinite(poses).all(axis=1)
        rows = np.flatnonzero(valid)
        self.tracked[rows] = poses[rows]
        self.tracked[rows, 2] = np.arctan2(np.sin(poses[rows, 2]), np.cos(poses[rows, 2]))
        return valid

    def set_ir(self, robot: int, raw: np.ndarray) -> None:
        """A robot's latest raw IR readings (ADC, right to left, as telemetry carries them)."""
        self.raw_ir[robot] = raw

    def ir_readings(self) -> tuple[np.ndarray, np.ndarray]:
        """Every robot's IR ranges [N, K] float32 from its telemetry, and whether each beam
        sees a robot [N, K], told from the tracked poses (:meth:`robot_flags`)."""
        ranges = self.calibration.to_ranges(self.raw_ir).reshape(self.raw_ir.shape)
        return ranges, self.robot_flags(ranges)

    def robot_flags(self, ranges: np.ndarray) -> np.ndarray:
        """[N, K] whether what each beam reports is a robot: the point it reports (body edge
        plus range along the beam) lies within ``robot_margin`` of another tracked robot's
        body and nearer to it than to any wall or obstacle."""
        poses, radius = self.tracked, self.mona.body_radius
        seen = np.isfinite(ranges)
        flags = np.zeros(ranges.shape, dtype=bool)
        if not seen.any() or len(poses) < 2:
            return flags
        robot, beam = np.nonzero(seen)
        heading = poses[robot, 2] + self.bearings[beam]
        reach = radius + ranges[robot, beam].astype(np.float64)
        points = np.column_stack([poses[robot, 0] + reach * np.cos(heading),
                                  poses[robot, 1] + reach * np.sin(heading),
                                  np.zeros(len(robot))])
        gaps = np.linalg.norm(points[:, None, :2] - poses[None, :, :2], axis=2) - radius
        gaps[np.arange(len(robot)), robot] = np.inf  # a robot does not see itself
        nearest = gaps.min(axis=1)
        flags[robot, beam] = (nearest <= self.robot_margin) & (nearest < self.clearance(points))
        return flags

    def step(self, linear: np.ndarray, angular: np.ndarray, cleaner: np.ndarray) -> None:
        """One step: the commands go to the robots (kept in :attr:`commanded`; held robots
        get a stop), the robots stay where the tracker saw them, and the cue is cleaned under
        those that clean (not the held ones) on a cleaning tick."""
        held = self.held
        linear = np.where(held, 0.0, np.asarray(linear, dtype=np.float64))
        angular = np.where(held, 0.0, np.asarray(angular, dtype=np.float64))
        self.commanded = (linear, angular)
        self.moved(np.asarray(cleaner, dtype=bool) & ~held)
