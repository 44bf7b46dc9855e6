"""A training program planned in silico (``microg plan training``): how many sessions until most
trainees are proficient, and how much of it a retention test finds left.

Each cohort is a whole simulated study of the program (``microg.insilico.simulate_trials``: every
trainee's sessions on the simulated calendar, each phase trained to a criterion planned task by task
as a session plans it, learning and forgetting across days by the simulated participant's model),
one Dask task per cohort. A cohort's seed derives from the run's seed, its size and its index, and
a compared program's cohort ``i`` has the seed of the planned one's: the same simulated people
(their draws come from the study's seed and their number), so the two differ only by their program.

What "proficient" means: a program's criterion is its group's first phase trained to one (its
``until``); a trainee is proficient at a session that trains that phase when the session met it, and
at a session without it (a test) when the session's tasks of that phase's kind meet the same rule,
``consecutive`` capped at the number of those tasks (a test of three objects can show two clean in a
row, not four).

``--out DIR`` receives ``run.json`` (the request, to resume), ``cohorts.csv`` (one row per cohort,
group and session, appended as cohorts finish, every digit kept), ``plan.csv`` (per program, group
and session: the share proficient with its 90 % band over cohorts, tasks to criterion, completion
time and the retention loss) and ``plan.png``.
"""

from __future__ import annotations

import dataclasses
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from tqdm import tqdm

from microg.power.design import PowerInputError
from microg.power.montecarlo import simulation_seed
from microg.power.run import P_FORMAT, claim_run, dask_client
from microg.study.progression import FinishedTask, progress
from microg.study.protocol import Criterion, Protocol

if TYPE_CHECKING:
    from microg.participant import Population

COHORTS, PLAN, PICTURE = "cohorts.csv", "plan.csv", "plan.png"
COHORT_COLUMNS = ("program", "cohort", "group", "session", "session_index", "day", "criterion_phase", "trainees",
                  "proficient", "tasks_to_criterion", "time_s")
"""``cohorts.csv``: per cohort, group and session, the share of its trainees proficient, the mean
tasks they ran in the criterion's phase until it was met or its bound (blank at a test) and the mean
completion time of the session's tasks of the criterion's kind."""
PLAN_COLUMNS = ("program", "protocol", "group", "session", "session_index", "day", "criterion_phase", "cohorts", "trainees",
                "proficient", "proficient_low", "proficient_high", "tasks_to_criterion", "tasks_low", "tasks_high",
                "time_s", "retention_loss_s")
"""``plan.csv``: per program (``plan``, or ``compare``: the --compare one; ``protocol`` its name),
group and session, over the cohorts: the mean share proficient with
its 90 % band (5th and 95th percentile), the median tasks to criterion with its band, the mean
completion time, and at the retention test its loss (its time minus the post-test's, s)."""
BAND = (5.0, 95.0)
PROGRAMS = ("plan", "compare")


@dataclass(frozen=True)
class ProgramRequest:
    """What ``plan_training`` computes: ``sims`` cohorts of ``n_per_group`` trainees per group of
    ``protocol`` (and of ``compare``, with the same people), drawn from ``population`` when given."""

    protocol: Protocol = field(compare=False)
    n_per_group: int
    sims: int
    seed: int = 1
    target: float = 0.8
    compare: Protocol | None = field(default=None, compare=False)
    population: Population | None = field(default=None, compare=False)

    def __post_init__(self):
        for program in self.programs.values():
            if not program.program:
                raise PowerInputError(f"--protocol {program.where}: declares no [[sessions]]; a training program "
                                      "is several sessions (see docs/study.md, Training programs)")
            untrained = [g.code for g in program.groups if _criterion(program, g.code) is None]
            if untrained:
                raise PowerInputError(f"{program.where}: group(s) {', '.join(untrained)} train to no criterion (no "
                                      "phase of theirs has until = {...}); a plan counts trainees proficient by it")
        if self.compare is not None and [g.code for g in self.compare.groups] != [g.code for g in self.protocol.groups]:
            raise PowerInputError(f"--compare {self.compare.where}: its groups {[g.code for g in self.compare.groups]} "
                                  f"differ from {[g.code for g in self.protocol.groups]}; the same simulated people "
                                  "need the same groups")
        if self.n_per_group < 1:
            raise PowerInputError(f"--n {self.n_per_group}: give at least one trainee per group")
        if self.sims < 1:
            raise PowerInputError(f"--sims {self.sims}: give at least one cohort")
        if not 0 < self.target <= 1:
            raise PowerInputError(f"--target {self.target}: a share of trainees, in (0, 1]")

    @property
    def programs(self) -> dict[str, Protocol]:
        return {"plan": self.protocol} | ({} if self.compare is None else {"compare": self.compare})

    def record(self) -> dict:
        """What a resumed run must match."""
        return {"protocol": self.protocol.resolved, "compare": None if self.compare is None else self.compare.resolved,
                "n_per_group": self.n_per_group, "sims": self.sims, "seed": self.seed,
                "population": None if self.population is None else self.population.where}


@dataclass(frozen=True)
class ProgramPlan:
    """A finished plan: ``plan.csv``'s table, its answer in words, and its folder."""

    table: pd.DataFrame
    words: list[str]
    out: Path


def plan_training(request: ProgramRequest, out: str | Path, scheduler: str | None = None,
                  workers: int | None = None, resume: bool = False, progress: bool = True) -> ProgramPlan:
    """Play ``request.sims`` cohorts through each program on Dask (one task per cohort; a local
    cluster of ``workers`` processes, or ``scheduler``), then write ``plan.csv`` and ``plan.png``
    into ``out`` and return the plan. ``resume`` continues the run in ``out``, playing only the
    cohorts it lacks; the result does not depend on the workers or on where the run stopped."""
    out = Path(out)
    claim_run(out, request.record(), resume, "a plan", (COHORTS, PLAN, PICTURE))
    cohorts = out / COHORTS
    rows = {name: sum(len(program.sessions_for(g.code)) for g in program.groups)
            for name, program in request.programs.items()}
    done = _finished(cohorts, rows) if resume else set()
    if not done:
        cohorts.write_text(",".join(COHORT_COLUMNS) + "\n")
    missing = [(name, i) for name in request.programs for i in range(request.sims) if (name, i) not in done]
    if missing:
        _compute(request, missing, cohorts, len(done), scheduler, workers, progress)
    played = pd.read_csv(cohorts, dtype={"group": str})
    table = plan_table(played, request)
    table.to_csv(out / PLAN, index=False)
    words = plan_words(table, played, request)
    plot_plan(table, request, out / PICTURE)
    return ProgramPlan(table, words, out)


def cohort_rows(program: Protocol, name: str, n_per_group: int, seed: int, index: int,
                population: Population | None = None) -> pd.DataFrame:
    """One cohort of ``program`` played in silico, as ``COHORT_COLUMNS`` rows (one Dask task)."""
    from microg.insilico import simulate_trials

    study_seed = int(simulation_seed(seed, n_per_group, index).generate_state(1)[0])
    trials = simulate_trials(program, n_per_group, study_seed, population=population)
    return cohort_summary(trials, program).assign(program=name, cohort=index)[list(COHORT_COLUMNS)]


def cohort_summary(trials: pd.DataFrame, program: Protocol) -> pd.DataFrame:
    """Per group and session of a program's trials table: the share of trainees proficient, their
    mean tasks to criterion and their mean completion time (see the module's docstring)."""
    rows = []
    for plan in program.sessions:
        for group in program.groups:
            if plan not in program.sessions_for(group.code):
                continue
            phase = _criterion(program, group.code)
            kind = program.kind(phase.name)
            session = trials[(trials["session"] == plan.name) & (trials["group"] == group.code)]
            judged = session[session["phase"].map(lambda p: program.phase(p) is not None and program.kind(p) == kind)
                             .astype(bool)]
            trained = phase.name in session["phase"].to_numpy()
            proficient, tasks = [], []
            for _, own in judged.groupby("participant", sort=True):
                own = own.sort_values("task_index")
                if trained:
                    ran = own[own["phase"] == phase.name]
                    proficient.append(bool(ran["criterion_met"].fillna(False).astype(bool).any()))
                    tasks.append(len(ran))
                else:
                    proficient.append(_meets(phase.until, own))
            days = (pd.to_datetime(session["session_date"]) - pd.to_datetime(trials.loc[
                trials["session_index"] == 1, "session_date"]).min()).dt.days
            rows.append({"group": group.code, "session": plan.name, "session_index": program.sessions.index(plan) + 1,
                         "day": int(days.median()) if len(days) else np.nan, "criterion_phase": phase.name,
                         "trainees": len(proficient), "proficient": np.mean(proficient) if proficient else np.nan,
                         "tasks_to_criterion": np.mean(tasks) if tasks else np.nan,
                         "time_s": judged["time_s"].mean()})
    return pd.DataFrame(rows)


def _meets(criterion: Criterion, tasks: pd.DataFrame) -> bool:
    """Whether a test's tasks (in order) meet ``criterion``, its ``consecutive`` capped at their number."""
    finished = [FinishedTask(r.object, r.status == "completed", None if pd.isna(r.time_s) else r.time_s,
                             None if pd.isna(r.attempts) else int(r.attempts)) for r in tasks.itertuples()]
    capped = dataclasses.replace(criterion, consecutive=min(criterion.consecutive, len(finished)))
    return bool(finished) and progress(capped, finished).met


def _criterion(program: Protocol, group: str):
    """The group's first phase trained to a criterion (None: it has none)."""
    return next((program.phase(p.name) for plan in program.sessions_for(group) for p in program.phases_for(group, plan.name)
                 if program.phase(p.name) is not None and program.phase(p.name).until is not None), None)


def plan_table(cohorts: pd.DataFrame, request: ProgramRequest) -> pd.DataFrame:
    """``plan.csv`` from ``cohorts.csv``'s rows (in any order: sorted first, so the numbers do not
    depend on which cohort finished first)."""
    cohorts = cohorts.sort_values(["program", "cohort", "session_index", "group"], kind="stable")
    rows = []
    keys = ["program", "group", "session", "session_index", "day", "criterion_phase"]
    for key, part in cohorts.groupby(keys, sort=False, dropna=False):
        shares, tasks = part["proficient"].dropna(), part["tasks_to_criterion"].dropna()
        rows.append(dict(zip(keys, key)) | {
            "cohorts": part["cohort"].nunique(), "trainees": int(part["trainees"].sum()),
            "proficient": shares.mean(), "proficient_low": _percentile(shares, BAND[0]),
            "proficient_high": _percentile(shares, BAND[1]), "tasks_to_criterion": tasks.median(),
            "tasks_low": _percentile(tasks, BAND[0]), "tasks_high": _percentile(tasks, BAND[1]),
            "time_s": part["time_s"].mean()})
    table = pd.DataFrame(rows, columns=[c for c in PLAN_COLUMNS if c not in ("protocol", "retention_loss_s")])
    table.insert(1, "protocol", table["program"].map(lambda name: request.programs[name].name))
    order = {name: i for i, name in enumerate(PROGRAMS)}
    table = table.sort_values(["program", "group", "session_index"], key=lambda c: c.map(order) if c.name == "program"
                              else c, kind="stable").reset_index(drop=True)
    table["retention_loss_s"] = np.nan
    for (name, group), part in table.groupby(["program", "group"], sort=False):
        roles = _test_roles(request.programs[name])
        if roles is None:
            continue
        post, retention = (part.loc[part["session"] == role, "time_s"] for role in roles)
        if len(post) and len(retention):
            table.loc[retention.index, "retention_loss_s"] = retention.iloc[0] - post.iloc[0]
    return table[list(PLAN_COLUMNS)]


def _percentile(values: pd.Series, q: float) -> float:
    return float(np.percentile(values, q)) if len(values) else np.nan


def _test_roles(program: Protocol) -> tuple[str, str] | None:
    """The post-test and the retention test (the last two sessions without a phase trained to a
    criterion, as the report names them); None: fewer than two such sessions."""
    tests = [plan.name for plan in program.sessions
             if not any(program.phase(p) is not None and program.phase(p).until is not None for p in plan.phases)]
    return (tests[-2], tests[-1]) if len(tests) >= 2 else None


def plan_words(table: pd.DataFrame, cohorts: pd.DataFrame, request: ProgramRequest) -> list[str]:
    """The answer in words, per program and group: after which session the target share is
    proficient (the median over cohorts of the first session at which each cohort reached it, with
    its 90 % band), and the share that still meets the criterion at the last session."""
    lines, target = [], f"{request.target * 100:.0f} %"
    for (name, group), part in table.groupby(["program", "group"], sort=False):
        program = request.programs[name]
        sessions = list(part["session"])
        own = cohorts[(cohorts["program"] == name) & (cohorts["group"] == group)]
        firsts = np.array([_first_reaching(rows.sort_values("session_index")["proficient"].to_numpy(), request.target)
                           for _, rows in own.groupby("cohort")])
        low, mid, high = (np.percentile(firsts, q, method="inverted_cdf") for q in (BAND[0], 50.0, BAND[1]))
        if np.isfinite(mid):
            named = [sessions[int(q)] if np.isfinite(q) else "not reached" for q in (low, high)]
            band = named[0] if low == high else "-".join(named)
            answer = f"{target} proficient after session {sessions[int(mid)]} (90 % band {band})"
        else:
            best = part.loc[part["proficient"].idxmax()]
            answer = (f"{target} proficient after no session in most cohorts (at best {best['proficient'] * 100:.0f} % "
                      f"after {best['session']})")
        last = part.iloc[-1]
        gap = int(last["day"] - part.iloc[-2]["day"]) if len(part) > 1 and pd.notna(last["day"]) else 0
        when = f"{gap} day{'s' if gap != 1 else ''} later, at {last['session']}," if gap else f"at {last['session']}"
        lines.append(f"{program.name}, group {group} ({program.group(group).name}): {answer}; {when} "
                     f"{last['proficient'] * 100:.0f} % still meet the criterion")
    return lines


def _first_reaching(shares: np.ndarray, target: float) -> float:
    """The index of the first share at least ``target`` (infinite: none)."""
    reached = np.flatnonzero(shares >= target - 1e-12)
    return float(reached[0]) if len(reached) else np.inf


def plot_plan(table: pd.DataFrame, request: ProgramRequest, path: Path) -> None:
    """Share proficient against session, a panel per group, a line per program (the compared one
    dashed) with its 90 % band over cohorts, the target dotted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = list(dict.fromkeys(table["group"]))
    fig, axes = plt.subplots(1, len(groups), figsize=(4.6 * len(groups), 4.2), sharey=True, layout="constrained",
                             squeeze=False)
    sessions = request.protocol.sessions
    for ax, group in zip(axes[0], groups):
        for name, program in request.programs.items():
            part = table[(table["program"] == name) & (table["group"] == group)]
            x = part["session_index"].to_numpy()
            days = ", ".join(f"{day:.0f}" for day in part["day"])
            line, = ax.plot(x, part["proficient"], marker="o", linestyle="-" if name == "plan" else "--",
                            label=f"{program.name} (days {days})")
            ax.fill_between(x, part["proficient_low"], part["proficient_high"], color=line.get_color(), alpha=0.12)
        ax.axhline(request.target, color="0.4", linewidth=0.8, linestyle=":")
        ax.set_xticks(range(1, len(sessions) + 1), [plan.name for plan in sessions], rotation=30)
        ax.set_title(f"group {group} ({request.protocol.group(group).name})", fontsize=10)
        ax.set_xlabel("session")
        ax.legend(fontsize=7, loc="lower center")
    axes[0][0].set_ylim(-0.02, 1.02)
    axes[0][0].set_ylabel("share of trainees proficient")
    fig.suptitle(f"{request.sims} cohorts of {request.n_per_group} trainees per group (bands: 90 % of cohorts)",
                 fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _compute(request: ProgramRequest, missing: list[tuple[str, int]], cohorts: Path, done: int,
             scheduler: str | None, workers: int | None, show: bool) -> None:
    """Play the ``missing`` cohorts on Dask, appending each one's rows to ``cohorts`` as it arrives."""
    from distributed import as_completed

    total = request.sims * len(request.programs)
    with dask_client(scheduler, workers) as client, cohorts.open("a") as sink, \
            tqdm(total=total, initial=done, unit=" cohorts", disable=not show, dynamic_ncols=True,
                 desc="training plan") as bar:
        futures = [client.submit(cohort_rows, request.programs[name], name, request.n_per_group, request.seed, index,
                                 request.population, pure=False) for name, index in missing]
        for future in as_completed(futures):
            rows = future.result()
            sink.write(rows.to_csv(header=False, index=False, float_format=P_FORMAT))
            sink.flush()
            os.fsync(sink.fileno())
            future.release()
            bar.set_postfix_str(f"workers {len(client.scheduler_info()['workers'])}")
            bar.update(1)


def _finished(cohorts: Path, rows: dict[str, int]) -> set[tuple[str, int]]:
    """The (program, cohort) pairs ``cohorts`` holds whole; the file is rewritten without the rest (a
    line or cohort cut off when the run was stopped)."""
    if not cohorts.exists():
        return set()
    whole = "".join(line for line in cohorts.read_text().splitlines(keepends=True) if line.endswith("\n"))
    if whole.count("\n") < 2:
        return set()
    table = pd.read_csv(io.StringIO(whole), dtype={"group": str})
    counts = table.groupby(["program", "cohort"]).size()
    complete = [key for key, n in counts.items() if n == rows.get(key[0])]
    kept = table[table.set_index(["program", "cohort"]).index.isin(complete)]
    partial = cohorts.with_suffix(".partial")
    kept.to_csv(partial, index=False, float_format=P_FORMAT)
    os.replace(partial, cohorts)
    return {(str(name), int(i)) for name, i in complete}
