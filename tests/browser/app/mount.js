// Mounts Foxglove's App as its own web build does (packages/studio-web/src/Root.tsx at
// v1.48.0), with an in-memory layout store holding the one layout the test serves at
// /layout.json under the id "mona-swarm" (the URL's layoutId), and in-memory settings, so a
// fresh browser profile opens the bag or the live view with the layout and no clicks.
/* global React, ReactDOM */
(async function mount() {
  "use strict";
  const studio = window; // the bundle's exports land on the global object
  const LAYOUT_ID = "mona-swarm";

  class MemoryLayoutStorage {
    constructor(layout) {
      this.layouts = new Map([[LAYOUT_ID, layout]]);
    }
    async list() { return [...this.layouts.values()]; }
    async get(_namespace, id) { return this.layouts.get(id); }
    async put(_namespace, layout) { this.layouts.set(layout.id, layout); return layout; }
    async delete(_namespace, id) { this.layouts.delete(id); }
    async migrateUnnamespacedLayouts() {}
    async importLayouts() {}
  }

  class MemoryConfiguration {
    constructor(values) { this.values = new Map(Object.entries(values)); this.listeners = new Map(); }
    get(key) { return this.values.get(key); }
    async set(key, value) {
      this.values.set(key, value);
      for (const listener of this.listeners.get(key) ?? []) { listener(value); }
    }
    addChangeListener(key, cb) {
      if (!this.listeners.has(key)) { this.listeners.set(key, new Set()); }
      this.listeners.get(key).add(cb);
    }
    removeChangeListener(key, cb) { this.listeners.get(key)?.delete(cb); }
  }

  const response = await fetch("/layout.json", { cache: "no-store" });
  if (!response.ok) { throw new Error(`/layout.json: HTTP ${response.status}`); }
  const data = await response.json();
  const layout = {
    id: LAYOUT_ID,
    name: "mona-swarm",
    permission: "CREATOR_WRITE",
    baseline: { data, savedAt: new Date(0).toISOString() },
    working: undefined,
    syncInfo: undefined,
  };

  studio.overwriteFetch();
  await studio.waitForFonts();
  await studio.initI18n();

  const settings = new MemoryConfiguration({
    [studio.AppSetting.COLOR_SCHEME]: "dark",
    [studio.AppSetting.TIMEZONE]: "UTC",
    [studio.AppSetting.TELEMETRY_ENABLED]: false,
    [studio.AppSetting.CRASH_REPORTING_ENABLED]: false,
    [studio.AppSetting.UPDATES_ENABLED]: false,
    [studio.AppSetting.SHOW_OPEN_DIALOG_ON_STARTUP]: false,
    [studio.AppSetting.HIDE_SIGN_IN_PROMPT]: true,
    [studio.AppSetting.LAUNCH_PREFERENCE]: "web",
  });
  const app = React.createElement(studio.App, {
    deepLinks: [window.location.href],
    dataSources: [
      new studio.RemoteDataSourceFactory(),
      new studio.FoxgloveWebSocketDataSourceFactory(),
      new studio.McapLocalDataSourceFactory(),
    ],
    appConfiguration: settings,
    layoutStorage: new MemoryLayoutStorage(layout),
    extensionLoaders: [],
    enableGlobalCss: true,
  });
  ReactDOM.render(app, document.getElementById("root"));
  window.monaSwarmMounted = true;
})().catch((error) => {
  console.error("mount failed:", error);
  window.monaSwarmMountError = String(error && error.stack || error);
});
