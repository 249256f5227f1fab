-- Schema: runs handed to a batch queue (Slurm job arrays, docs/slurm.md). A queued run stays
-- 'running' and points at its array and index: the job outlives the runner that submitted it,
-- so a restarted runner re-attaches to it instead of starting the run a second time.
CREATE TABLE job_arrays (
  id INTEGER PRIMARY KEY,
  dir TEXT NOT NULL,          -- the submission's directory: manifest.tsv, batch scripts, Slurm's logs
  script TEXT NOT NULL UNIQUE,-- the batch script of this sbatch call
  name TEXT NOT NULL,         -- the job name: finds the job again if the runner died inside sbatch
  array TEXT NOT NULL,        -- the --array value submitted, e.g. "0-999%50" or "3,17"
  job_id TEXT,                -- the array job id sbatch printed; NULL until sbatch returned
  submitted_at REAL NOT NULL
);
ALTER TABLE runs ADD COLUMN job_array INTEGER REFERENCES job_arrays (id);
ALTER TABLE runs ADD COLUMN job_index INTEGER;
ALTER TABLE runs ADD COLUMN job_state TEXT;  -- the queue state last seen: PENDING, RUNNING, ...
CREATE INDEX runs_job_array ON runs (job_array);
