-- Schema version 2: keep the whole summary.json of a finished run, and the last progress seen.
ALTER TABLE runs ADD COLUMN summary TEXT;
ALTER TABLE runs ADD COLUMN progress TEXT;
