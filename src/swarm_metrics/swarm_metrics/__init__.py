"""The study's metrics, bag recording and analysis, and the metrics node."""
