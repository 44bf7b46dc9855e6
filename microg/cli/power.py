"""``microg power``: how many participants the protocol's design needs (exact or Monte Carlo power,
on a local or an existing Dask cluster)."""

from __future__ import annotations

import functools
from pathlib import Path

import click

from microg.cli.common import SEED, ExistingPath, clear_errors, renamed


def power_errors(command):
    """The power room's own errors as ``Error: <message>`` (exit status 1), without a traceback."""
    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from microg.power import PowerInputError

        try:
            return command(*args, **kwargs)
        except PowerInputError as error:
            raise click.ClickException(str(error)) from None
    return wrapper


def profile_population(profile: Path | None):
    """The population of ``--profile`` (None without one), its errors as the option's."""
    if profile is None:
        return None
    from microg.participant import PopulationError, read_population

    try:
        return read_population(profile)
    except PopulationError as error:
        raise click.BadParameter(str(error), param_hint="--profile") from None


def _sizes(text: str) -> tuple:
    """Group sizes to plan for: ``8,10,15`` (equal groups of each size) or ``veteran=15,beginner=12``
    (one sample, a size per group)."""
    named = "=" in text
    sizes = {} if named else []
    for part in (piece.strip() for piece in text.split(",")):
        name, _, number = part.rpartition("=") if named else ("", "", part)
        if named and not name:
            raise click.BadParameter(f"{part!r}: give every group as NAME=SIZE (e.g. --n veteran=15,beginner=12)",
                                     param_hint="--n")  # fmt: skip
        try:
            size = int(number)
        except ValueError:
            raise click.BadParameter(f"{number!r} is not a whole number (e.g. --n 8,10,15,20 or "
                                     "--n veteran=15,beginner=12)", param_hint="--n") from None  # fmt: skip
        if named:
            sizes[name.strip()] = size
        else:
            sizes.append(size)
    return (sizes,) if named else tuple(sizes)


def _effect_sizes(texts: tuple[str, ...], terms: tuple[str, ...]) -> tuple:
    """``--effect-size [TEST:]f=0.25`` or ``[TEST:]np2=0.06`` -> ((test, kind, value), ...); without
    a test, every ANOVA term."""
    found = []
    for text in texts:
        test, _, size = text.rpartition(":")
        kind, _, number = size.partition("=")
        try:
            value = float(number)
        except ValueError:
            raise click.BadParameter(f"{text!r}: write [TEST:]f=VALUE or [TEST:]np2=VALUE (e.g. object:f=0.25)",
                                     param_hint="--effect-size") from None  # fmt: skip
        found += [(name, kind.strip(), value) for name in ([test.strip()] if test.strip() else terms)]
    return tuple(found)


@click.command("power")
@click.option("--protocol", default="paper", show_default=True, help="Protocol name or file: the design's groups, "
              "objects and interaction models.")  # fmt: skip
@click.option("--within", type=click.Choice(["object", "interaction"]), default="object", show_default=True,
              help="The within factor: the objects, or the interaction models of the phases (stage1 vs stage2; "
                   "a participant's value per interaction model is the mean over objects).")  # fmt: skip
@click.option("--effects", "effects_file", type=click.Path(dir_okay=False, path_type=Path),
              help="TOML file of cell means per group and level, with sd and correlation (numbers, or an SD per group "
                   "and level and a correlation matrix per group) or a covariance per group.")
@click.option("--pilot", type=ExistingPath(path_type=Path),
              help="A pilot study (folder) or its exported trials.csv/.parquet: means and covariance estimated "
                   "from it.")  # fmt: skip
@click.option("--simulated", is_flag=True, help="In-silico studies: whole studies of the protocol's simulated "
              "participants played through the physics (batched; the trials table a logged study would have), one "
              "Dask task per study.")  # fmt: skip
@click.option("--profile", type=ExistingPath(dir_okay=False, path_type=Path), default=None,
              help="--simulated: a population file (PROFILE.toml, microg participant calibrate writes one) that every "
                   "group's simulated participants are drawn from; default: each group's simulated_profile.")
@click.option("--effect-size", "effect_sizes", multiple=True, metavar="[TEST:]f=F|np2=ETA",
              help="The effect of a test as Cohen's f or partial eta squared, instead of --effects (repeatable; "
                   "without TEST every ANOVA term; Superpower's convention: lambda = f^2 df2).")
@click.option("--method", type=click.Choice(["exact", "montecarlo"]), default=None,
              help="exact (noncentral F on an exact data set) or montecarlo (simulated data sets analysed as the "
                   "report does). [default: exact; montecarlo with --simulated]")
@click.option("--sensitivity", is_flag=True,
              help="For each --n, the smallest effect each test detects with power --target: as a scaling of the "
                   "--effects' pattern of means (when given), as partial eta squared and as Cohen's f (exact).")
@click.option("--correction", type=click.Choice(["mauchly", "none", "GG", "HF"]), default=None,
              help="Sphericity: mauchly (the report's rule: Greenhouse-Geisser where Mauchly's test rejects; Monte "
                   "Carlo only), none, or always GG / HF (exact: df and lambda times epsilon, as Superpower). "
                   "[default: mauchly for montecarlo, none for exact]")
@click.option("--sims", type=int, default=1000, show_default=True, help="Monte Carlo: data sets (or studies) per n.")
@click.option("--n", "sizes", default="8,10,15,20", show_default=True,
              help="Participants per group, comma-separated; or one size per group: veteran=15,beginner=12.")
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for power.csv, power-curve.png, summary.json (and simulations.csv, run.json).")
@click.option("--target", type=float, default=0.8, show_default=True, help="Power to reach.")
@click.option("--alpha", type=float, default=0.05, show_default=True,
              help="Significance level (also the level of Mauchly's test, as in the report).")
@click.option("--scheduler", default=None, metavar="tcp://HOST:PORT",
              help="An existing Dask scheduler; default: a local cluster on this machine's cores.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes of the local cluster [default: one per core].")
@click.option("--seed", type=SEED, default=1, show_default=True,
              help="Seed of the run; each data set's seed derives from it and the data set's index.")
@click.option("--resume", is_flag=True, help="Continue the run in --out where it stopped (same settings).")
@click.option("--batch", type=click.IntRange(min=1), default=100, show_default=True,
              help="Monte Carlo: data sets per Dask task.")
@click.option("--measure", type=click.Choice(["time_s", "attempts"]), default="time_s", show_default=True,
              help="--pilot and --simulated: the measure.")
@click.option("--interaction", default=None, help="--pilot and --simulated: the interaction model whose tasks are read "
              "(with --within object) [default: the first phase's].")  # fmt: skip
@renamed("--system", "--interaction")
@clear_errors
@power_errors
def power(*, protocol: str, within: str, effects_file: Path | None, pilot: Path | None, simulated: bool,
          profile: Path | None, effect_sizes: tuple[str, ...], method: str | None, sensitivity: bool, correction: str | None, sims: int,
          sizes: str, out: Path, target: float, alpha: float, scheduler: str | None, workers: int | None, seed: int,
          resume: bool, batch: int, measure: str, interaction: str | None) -> None:
    """How many participants per group the design needs: power of each ANOVA term and post hoc
    contrast for each --n, from --effects, a --pilot, --effect-size or --simulated studies; or, with
    --sensitivity, the smallest effect each test detects at each --n.

    Writes OUT/power.csv (n_per_group, term, power, ci_low, ci_high, method), OUT/power-curve.png
    and OUT/summary.json (the smallest n per group that reaches --target), and prints them; with
    --sensitivity OUT/sensitivity.csv (n_per_group, term, scale, np2, cohen_f, noncentrality, df1,
    df2, epsilon, power) and OUT/summary.json.
    """
    from microg.paths import protocol_file
    from microg.power import (
        PowerRequest,
        design_from_protocol,
        pilot_effects,
        read_effects,
        run_power,
    )
    from microg.study.protocol import load_protocol

    given = [name for name, value in (("--effects", effects_file), ("--pilot", pilot), ("--simulated", simulated),
                                      ("--effect-size", effect_sizes)) if value]  # fmt: skip
    if sensitivity:
        if len(given) > 1 or set(given) - {"--effects", "--pilot"}:
            raise click.UsageError(f"--sensitivity takes the pattern of --effects or --pilot, or none (not "
                                   f"{' and '.join(given)})")  # fmt: skip
    elif len(given) != 1:
        raise click.UsageError("give exactly one of --effects FILE, --pilot STUDY|TABLE, --effect-size, --simulated"
                               + (f" (not {' and '.join(given)})" if given else ""))
    population = profile_population(profile)
    rules = load_protocol(protocol_file(protocol))
    if simulated:
        problems = rules.player_problems() if population is None else []
        if problems:
            raise click.ClickException("\n".join(problems))
    design = design_from_protocol(rules, within)
    if interaction is not None and interaction not in design.interactions:
        raise click.BadParameter(f"{interaction!r} is not an interaction model of protocol {rules.name!r} "
                                 f"({', '.join(design.interactions)})", param_hint="--interaction")  # fmt: skip
    effects = estimate = None
    if effects_file is not None:
        effects = read_effects(effects_file, design)
    elif pilot is not None:
        estimate = pilot_effects(pilot, design, measure, interaction)
        effects = estimate.effects
        click.echo(estimate.describe() + "\n")
    samples = tuple(design.group_sizes(n) if isinstance(n, dict) else n for n in _sizes(sizes))
    request = PowerRequest(design, method or ("montecarlo" if simulated else "exact"), samples, effects,
                           rules, alpha, target, sims, seed, measure, interaction, correction, sensitivity,
                           _effect_sizes(effect_sizes, design.terms), population)  # fmt: skip
    result = run_power(request, out, scheduler, workers, resume, progress=True, batch=batch)
    if estimate is not None:
        (out / "effects.toml").write_text(estimate.effects.to_toml())
        click.echo(f"the pilot's estimates -> {out / 'effects.toml'} (edit and rerun with --effects to explore)")
    if sensitivity:
        _print_sensitivity(result, request)
        return

    table = result.table
    wide = table.pivot(index="term", columns="n_per_group", values="power").loc[list(dict.fromkeys(table["term"]))]
    wide.columns = [f"n={n}" for n in wide.columns]
    smallest = result.summary["smallest_n_per_group"]
    largest = max(request.samples) if all(isinstance(key, int) for key in request.samples) else None
    wide[f"n for {target:g}"] = [str(smallest[term]) if smallest[term] is not None
                                 else (f"> {largest}" if largest is not None else "not reached")
                                 for term in wide.index]  # fmt: skip
    click.echo(f"power ({request.method}, {request.source}; alpha {alpha:g}"
               + (f", {sims} {'studies' if simulated else 'data sets'} per n, {result.summary['seconds']:.1f} s"
                  if request.method == "montecarlo" else "")
               + f"; {_CORRECTIONS[request.read]}):")  # fmt: skip
    click.echo(wide.to_string(float_format=lambda v: f"{v:.3f}"))
    click.echo(f"-> {out / 'power.csv'}, {out / 'power-curve.png'}, {out / 'summary.json'}")


_CORRECTIONS = {"mauchly": "Greenhouse-Geisser where Mauchly's test rejects", "none": "sphericity assumed",
                "GG": "Greenhouse-Geisser corrected", "HF": "Huynh-Feldt corrected"}  # fmt: skip


def _print_sensitivity(result, request) -> None:
    table = result.table
    click.echo(f"smallest effect with power {request.target:g} (exact, alpha {request.alpha:g}, "
               f"{_CORRECTIONS[request.read]}; np2 and f by Superpower's convention, lambda = f^2 df2):")  # fmt: skip
    shown = ["np2", "cohen_f"] + (["scale"] if request.effects is not None else [])
    for key, rows in table.groupby("n_per_group", sort=False):
        click.echo(f"n per group = {key}:")
        click.echo(rows.set_index("term")[shown].to_string(float_format=lambda v: f"{v:.4f}"))
    if request.effects is not None:
        click.echo("scale: the factor by which every mean's deviation from the grand mean must grow (1 = the "
                   "pattern as given; inf = the pattern has no such effect)")
    click.echo(f"-> {result.out / 'sensitivity.csv'}, {result.out / 'summary.json'}")


COMMANDS = [power]
