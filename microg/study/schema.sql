-- The study's log store (microg.study.store): tables, then the triggers that keep it append-only
-- and that log nothing for a session or task run after its end. Opening a study checks they are all here.
-- frames: one row per committed batch of logged frames, encoded by microg.study.framelog, with its checksum.
-- ledger: one entry per fact committed, in a hash chain (microg.study.ledger).
-- sessions: a participant's sittings (one, or a training program's: name, index, date on the calendar or
-- simulated, the date it was due from, whether it ran before that ignoring the schedule).
-- tasks: a session's planned tasks; a phase that trains to a criterion adds its tasks as they run.
-- stations: the stations made from a central study; a station's study holds its own row (microg.study.stations).
-- station_give_ups: a participant handed to a station and taken back by the central study (microg study station --give-up).
CREATE TABLE study (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    name TEXT NOT NULL,
    seed INTEGER NOT NULL,
    protocol_id INTEGER NOT NULL REFERENCES protocols(id),
    created_at TEXT NOT NULL,
    microg_version TEXT NOT NULL,
    schema_version INTEGER NOT NULL,
    station TEXT
);
CREATE TABLE protocols (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL,
    sha256 TEXT NOT NULL UNIQUE,
    resolved TEXT NOT NULL,
    source_text TEXT NOT NULL,
    added_at TEXT NOT NULL
);
CREATE TABLE participants (
    id TEXT PRIMARY KEY,
    number INTEGER NOT NULL UNIQUE,
    group_code TEXT NOT NULL,
    gender TEXT NOT NULL,
    age INTEGER NOT NULL,
    handedness TEXT NOT NULL,
    mr_experience INTEGER NOT NULL,
    order_row INTEGER,
    object_order TEXT NOT NULL,
    status TEXT NOT NULL DEFAULT 'active' CHECK (status IN ('active', 'withdrawn')),
    added_at TEXT NOT NULL,
    withdrawn_at TEXT,
    withdraw_reason TEXT
);
CREATE TABLE sessions (
    id INTEGER PRIMARY KEY,
    participant_id TEXT NOT NULL REFERENCES participants(id),
    name TEXT NOT NULL,
    session_index INTEGER NOT NULL CHECK (session_index >= 1),
    date TEXT NOT NULL,
    date_simulated INTEGER NOT NULL,
    due TEXT NOT NULL,
    ignored_schedule INTEGER NOT NULL,
    protocol_id INTEGER NOT NULL REFERENCES protocols(id),
    seed INTEGER NOT NULL,
    input TEXT NOT NULL,
    simulated INTEGER NOT NULL,
    clock TEXT NOT NULL,
    object_order TEXT NOT NULL,
    microg_version TEXT NOT NULL,
    python TEXT NOT NULL,
    platform TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('running', 'completed', 'incomplete', 'aborted')),
    created_at TEXT NOT NULL,
    ended_at TEXT,
    station TEXT,
    merged_at TEXT,
    UNIQUE (participant_id, name),
    UNIQUE (participant_id, session_index)
);
CREATE TABLE tasks (
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    task_index INTEGER NOT NULL,
    phase TEXT NOT NULL,
    interaction TEXT NOT NULL,
    object TEXT NOT NULL,
    object_code TEXT NOT NULL,
    order_position INTEGER NOT NULL,
    task_in_phase INTEGER NOT NULL,
    difficulty REAL,
    PRIMARY KEY (session_id, task_index)
);
CREATE TABLE task_runs (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL,
    task_index INTEGER NOT NULL,
    run INTEGER NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('running', 'completed', 'timeout', 'aborted', 'skipped', 'interrupted')),
    reason TEXT,
    source TEXT NOT NULL,
    seed INTEGER NOT NULL,
    started_at REAL NOT NULL,
    ended_at REAL,
    time_s REAL,
    attempts INTEGER,
    frames INTEGER,
    started_wall TEXT NOT NULL,
    ended_wall TEXT,
    UNIQUE (session_id, task_index, run),
    FOREIGN KEY (session_id, task_index) REFERENCES tasks(session_id, task_index)
);
CREATE TABLE events (
    id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    run_id INTEGER REFERENCES task_runs(id),
    t REAL NOT NULL,
    wall TEXT NOT NULL,
    kind TEXT NOT NULL,
    data TEXT NOT NULL
);
CREATE INDEX events_by_session ON events(session_id, run_id);
-- answers: one row per item answered, committed as it is given. interaction is '' for a questionnaire about
-- no interaction model; value is a number on the item's scale or the choice made (a NASA-TLX pair's subscale);
-- response_time_s runs from showing the item to the answer that counted (NULL for the rating model).
CREATE TABLE answers (
    session_id INTEGER NOT NULL REFERENCES sessions(id),
    instrument TEXT NOT NULL,
    administration TEXT NOT NULL,
    interaction TEXT NOT NULL,
    item TEXT NOT NULL,
    value NOT NULL CHECK (typeof(value) IN ('integer', 'real', 'text')),
    source TEXT NOT NULL CHECK (source IN ('participant', 'model')),
    response_time_s REAL CHECK (response_time_s IS NULL OR response_time_s >= 0),
    t REAL NOT NULL,
    wall TEXT NOT NULL,
    PRIMARY KEY (session_id, instrument, administration, interaction, item)
);
CREATE TABLE frames (
    run_id INTEGER NOT NULL REFERENCES task_runs(id),
    first INTEGER NOT NULL,
    count INTEGER NOT NULL CHECK (count > 0),
    t_first REAL NOT NULL,
    t_last REAL NOT NULL,
    checksum BLOB NOT NULL,
    data BLOB NOT NULL,
    PRIMARY KEY (run_id, first)
);
CREATE TABLE stations (
    name TEXT PRIMARY KEY,
    participants TEXT NOT NULL,
    made_at TEXT NOT NULL
);
CREATE TABLE station_give_ups (
    station TEXT NOT NULL REFERENCES stations(name),
    participant TEXT NOT NULL REFERENCES participants(id),
    given_up_at TEXT NOT NULL,
    reason TEXT,
    PRIMARY KEY (station, participant)
);
CREATE TABLE ledger (
    seq INTEGER PRIMARY KEY,
    fact TEXT NOT NULL,
    key TEXT NOT NULL,
    digest BLOB NOT NULL,
    link BLOB NOT NULL,
    UNIQUE (fact, key)
);

CREATE TRIGGER study_no_update BEFORE UPDATE ON study
BEGIN SELECT RAISE(ABORT, 'study rows are never changed: the log is append-only'); END;
CREATE TRIGGER study_no_delete BEFORE DELETE ON study
BEGIN SELECT RAISE(ABORT, 'study rows are never deleted: the log is append-only'); END;

CREATE TRIGGER protocols_no_update BEFORE UPDATE ON protocols
BEGIN SELECT RAISE(ABORT, 'protocols rows are never changed: the log is append-only'); END;
CREATE TRIGGER protocols_no_delete BEFORE DELETE ON protocols
BEGIN SELECT RAISE(ABORT, 'protocols rows are never deleted: the log is append-only'); END;

CREATE TRIGGER tasks_no_update BEFORE UPDATE ON tasks
BEGIN SELECT RAISE(ABORT, 'tasks rows are never changed: the log is append-only'); END;
CREATE TRIGGER tasks_no_delete BEFORE DELETE ON tasks
BEGIN SELECT RAISE(ABORT, 'tasks rows are never deleted: the log is append-only'); END;

CREATE TRIGGER events_no_update BEFORE UPDATE ON events
BEGIN SELECT RAISE(ABORT, 'events rows are never changed: the log is append-only'); END;
CREATE TRIGGER events_no_delete BEFORE DELETE ON events
BEGIN SELECT RAISE(ABORT, 'events rows are never deleted: the log is append-only'); END;

CREATE TRIGGER answers_no_update BEFORE UPDATE ON answers
BEGIN SELECT RAISE(ABORT, 'answers rows are never changed: the log is append-only'); END;
CREATE TRIGGER answers_no_delete BEFORE DELETE ON answers
BEGIN SELECT RAISE(ABORT, 'answers rows are never deleted: the log is append-only'); END;

CREATE TRIGGER frames_no_update BEFORE UPDATE ON frames
BEGIN SELECT RAISE(ABORT, 'frames rows are never changed: the log is append-only'); END;
CREATE TRIGGER frames_no_delete BEFORE DELETE ON frames
BEGIN SELECT RAISE(ABORT, 'frames rows are never deleted: the log is append-only'); END;

CREATE TRIGGER stations_no_update BEFORE UPDATE ON stations
BEGIN SELECT RAISE(ABORT, 'stations rows are never changed: the log is append-only'); END;
CREATE TRIGGER stations_no_delete BEFORE DELETE ON stations
BEGIN SELECT RAISE(ABORT, 'stations rows are never deleted: the log is append-only'); END;

CREATE TRIGGER station_give_ups_no_update BEFORE UPDATE ON station_give_ups
BEGIN SELECT RAISE(ABORT, 'station_give_ups rows are never changed: the log is append-only'); END;
CREATE TRIGGER station_give_ups_no_delete BEFORE DELETE ON station_give_ups
BEGIN SELECT RAISE(ABORT, 'station_give_ups rows are never deleted: the log is append-only'); END;

CREATE TRIGGER ledger_no_update BEFORE UPDATE ON ledger
BEGIN SELECT RAISE(ABORT, 'ledger rows are never changed: the log is append-only'); END;
CREATE TRIGGER ledger_no_delete BEFORE DELETE ON ledger
BEGIN SELECT RAISE(ABORT, 'ledger rows are never deleted: the log is append-only'); END;

CREATE TRIGGER task_runs_once BEFORE UPDATE ON task_runs
WHEN OLD.status != 'running' OR NEW.status = 'running'
  OR NEW.session_id IS NOT OLD.session_id OR NEW.task_index IS NOT OLD.task_index OR NEW.run IS NOT OLD.run
  OR NEW.started_at IS NOT OLD.started_at OR NEW.seed IS NOT OLD.seed OR NEW.source IS NOT OLD.source
BEGIN SELECT RAISE(ABORT, 'a finished task run is never changed'); END;
CREATE TRIGGER sessions_once BEFORE UPDATE ON sessions
WHEN OLD.status != 'running' OR NEW.status = 'running' OR NEW.participant_id IS NOT OLD.participant_id
  OR NEW.seed IS NOT OLD.seed OR NEW.protocol_id IS NOT OLD.protocol_id OR NEW.created_at IS NOT OLD.created_at
  OR NEW.station IS NOT OLD.station OR NEW.merged_at IS NOT OLD.merged_at OR NEW.name IS NOT OLD.name
  OR NEW.session_index IS NOT OLD.session_index OR NEW.date IS NOT OLD.date
  OR NEW.date_simulated IS NOT OLD.date_simulated OR NEW.due IS NOT OLD.due
  OR NEW.ignored_schedule IS NOT OLD.ignored_schedule
BEGIN SELECT RAISE(ABORT, 'a finished session is never changed'); END;
CREATE TRIGGER participants_withdraw_only BEFORE UPDATE ON participants
WHEN OLD.status != 'active' OR NEW.status != 'withdrawn' OR NEW.id IS NOT OLD.id OR NEW.number IS NOT OLD.number
  OR NEW.group_code IS NOT OLD.group_code OR NEW.gender IS NOT OLD.gender OR NEW.age IS NOT OLD.age
  OR NEW.handedness IS NOT OLD.handedness OR NEW.mr_experience IS NOT OLD.mr_experience
  OR NEW.object_order IS NOT OLD.object_order OR NEW.order_row IS NOT OLD.order_row
BEGIN SELECT RAISE(ABORT, 'a participant can only be withdrawn, once; demographics are never changed'); END;
CREATE TRIGGER runs_no_delete BEFORE DELETE ON task_runs
BEGIN SELECT RAISE(ABORT, 'task_runs rows are never deleted'); END;
CREATE TRIGGER sessions_no_delete BEFORE DELETE ON sessions
BEGIN SELECT RAISE(ABORT, 'sessions rows are never deleted'); END;
CREATE TRIGGER participants_no_delete BEFORE DELETE ON participants
BEGIN SELECT RAISE(ABORT, 'participants rows are never deleted (withdraw instead)'); END;

CREATE TRIGGER events_while_running BEFORE INSERT ON events
WHEN (SELECT status FROM sessions WHERE id = NEW.session_id) IS NOT 'running'
BEGIN SELECT RAISE(ABORT, 'the session has ended: nothing is logged after its end'); END;
CREATE TRIGGER answers_while_running BEFORE INSERT ON answers
WHEN (SELECT status FROM sessions WHERE id = NEW.session_id) IS NOT 'running'
BEGIN SELECT RAISE(ABORT, 'the session has ended: nothing is logged after its end'); END;
CREATE TRIGGER tasks_while_running BEFORE INSERT ON tasks
WHEN (SELECT status FROM sessions WHERE id = NEW.session_id) IS NOT 'running'
BEGIN SELECT RAISE(ABORT, 'the session has ended: no tasks are planned after its end'); END;
CREATE TRIGGER runs_while_running BEFORE INSERT ON task_runs
WHEN (SELECT status FROM sessions WHERE id = NEW.session_id) IS NOT 'running'
BEGIN SELECT RAISE(ABORT, 'the session has ended: no task runs after its end'); END;
CREATE TRIGGER frames_while_running BEFORE INSERT ON frames
WHEN (SELECT status FROM task_runs WHERE id = NEW.run_id) IS NOT 'running'
BEGIN SELECT RAISE(ABORT, 'the task run has ended: no frames are logged after its end'); END;
