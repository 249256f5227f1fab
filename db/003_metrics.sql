-- Schema version 3: the per-run metrics of the registered analyses (docs/analyses.md), stored by
-- campaign report, export and compare, so that a SELECT answers "Q against W" with no report.
CREATE TABLE metrics (
  run_id TEXT NOT NULL REFERENCES runs (run_id),
  analysis TEXT NOT NULL,
  metric TEXT NOT NULL,
  value REAL,
  se REAL,
  unit TEXT NOT NULL,
  PRIMARY KEY (run_id, analysis, metric)
);
CREATE INDEX metrics_by_metric ON metrics (metric, run_id);
-- Which version of an analysis, with which options, produced a run's metrics.
CREATE TABLE analyses (
  run_id TEXT NOT NULL REFERENCES runs (run_id),
  analysis TEXT NOT NULL,
  version INTEGER NOT NULL,
  options TEXT NOT NULL,
  analysed_at REAL NOT NULL,
  PRIMARY KEY (run_id, analysis)
);
-- The metrics of finished runs with their sweep point, replica and engine.
CREATE VIEW run_metrics AS
  SELECT r.run_id, r.point_id, r.point, r.replica, r.engine, m.analysis, m.metric, m.value, m.se, m.unit
  FROM metrics m JOIN runs r USING (run_id)
  WHERE r.state = 'done';
