-- Schema version 1: the campaign, its runs and their scalar results.
CREATE TABLE campaign (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  name TEXT NOT NULL,
  spec TEXT NOT NULL,
  spec_hash TEXT NOT NULL,
  axes TEXT NOT NULL,
  granary_version TEXT NOT NULL,
  git_commit TEXT NOT NULL,
  planned_at REAL NOT NULL
);
CREATE TABLE runs (
  run_id TEXT PRIMARY KEY NOT NULL,
  seq INTEGER NOT NULL,
  point_id TEXT NOT NULL,
  point TEXT NOT NULL,
  replica INTEGER NOT NULL,
  params TEXT NOT NULL,
  state TEXT NOT NULL CHECK (state IN ('planned', 'running', 'done', 'failed', 'interrupted', 'retired')),
  retired_from TEXT,
  attempts INTEGER NOT NULL DEFAULT 0,
  engine TEXT NOT NULL,
  engine_version TEXT,
  granary_version TEXT,
  git_commit TEXT,
  host TEXT,
  started_at REAL,
  ended_at REAL,
  wall_s REAL,
  end_reason TEXT,
  run_dir TEXT NOT NULL,
  failure TEXT,
  lease_holder TEXT,
  lease_host TEXT,
  lease_pid INTEGER,
  lease_heartbeat REAL
);
CREATE INDEX runs_state ON runs (state, seq);
CREATE TABLE results (
  run_id TEXT NOT NULL REFERENCES runs (run_id),
  key TEXT NOT NULL,
  value REAL,
  text TEXT,
  PRIMARY KEY (run_id, key)
);
