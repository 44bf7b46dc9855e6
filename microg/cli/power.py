"""``microg power``: how many participants the protocol's design needs (exact or Monte Carlo power,
on a local or an existing Dask cluster)."""

from __future__ import annotations

import functools
from pathlib import Path

import click

from microg.cli.common import SEED, ExistingPath, clear_errors, renamed


def _power_errors(command):
    """The power room's own errors as ``Error: <message>`` (exit status 1), without a traceback."""
    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from microg.power import PowerInputError

        try:
            return command(*args, **kwargs)
        except PowerInputError as error:
            raise click.ClickException(str(error)) from None
    return wrapper


def _sizes(text: str) -> tuple[int, ...]:
    sizes = []
    for part in text.split(","):
        try:
            sizes.append(int(part.strip()))
        except ValueError:
            raise click.BadParameter(f"{part.strip()!r} is not a whole number (e.g. --n 8,10,15,20)",
                                     param_hint="--n") from None  # fmt: skip
    return tuple(sizes)


@click.command("power")
@click.option("--protocol", default="paper", show_default=True, help="Protocol name or file: the design's groups, "
              "objects and interaction models.")  # fmt: skip
@click.option("--within", type=click.Choice(["object", "interaction"]), default="object", show_default=True,
              help="The within factor: the objects, or the interaction models of the phases (stage1 vs stage2; "
                   "a participant's value per interaction model is the mean over objects).")  # fmt: skip
@click.option("--effects", "effects_file", type=click.Path(dir_okay=False, path_type=Path),
              help="TOML file of cell means per group and level, with sd + correlation or a covariance per group.")
@click.option("--pilot", type=ExistingPath(path_type=Path),
              help="A pilot study (folder) or its exported trials.csv/.parquet: means and covariance estimated "
                   "from it.")  # fmt: skip
@click.option("--simulated", is_flag=True, help="In-silico studies: the real sessions with simulated participants "
              "and physics, one Dask task per study (slow).")  # fmt: skip
@click.option("--method", type=click.Choice(["exact", "montecarlo"]), default=None,
              help="exact (noncentral F on an exact data set; sphericity assumed) or montecarlo (simulated data "
                   "sets analysed as the report does). [default: exact; montecarlo with --simulated]")
@click.option("--sims", type=int, default=1000, show_default=True, help="Monte Carlo: data sets (or studies) per n.")
@click.option("--n", "sizes", default="8,10,15,20", show_default=True, help="Participants per group, comma-separated.")
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
@_power_errors
def power(protocol: str, within: str, effects_file: Path | None, pilot: Path | None, simulated: bool,
          method: str | None, sims: int, sizes: str, out: Path, target: float, alpha: float, scheduler: str | None,
          workers: int | None, seed: int, resume: bool, batch: int, measure: str, interaction: str | None) -> None:
    """How many participants per group the design needs: power of each ANOVA term and post hoc
    contrast for each --n, from --effects, a --pilot or --simulated studies.

    Writes OUT/power.csv (n_per_group, term, power, ci_low, ci_high, method), OUT/power-curve.png
    and OUT/summary.json (the smallest n per group that reaches --target), and prints them.
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

    given = [name for name, value in (("--effects", effects_file), ("--pilot", pilot), ("--simulated", simulated))
             if value]  # fmt: skip
    if len(given) != 1:
        raise click.UsageError("give exactly one of --effects FILE, --pilot STUDY|TABLE, --simulated"
                               + (f" (not {' and '.join(given)})" if given else ""))
    rules = load_protocol(protocol_file(protocol))
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
    request = PowerRequest(design, method or ("montecarlo" if simulated else "exact"), _sizes(sizes), effects,
                           rules, alpha, target, sims, seed, measure, interaction)  # fmt: skip
    result = run_power(request, out, scheduler, workers, resume, progress=True, batch=batch)
    if estimate is not None:
        (out / "effects.toml").write_text(estimate.effects.to_toml())
        click.echo(f"the pilot's estimates -> {out / 'effects.toml'} (edit and rerun with --effects to explore)")

    table = result.table
    wide = table.pivot(index="term", columns="n_per_group", values="power").loc[list(dict.fromkeys(table["term"]))]
    wide.columns = [f"n={n}" for n in wide.columns]
    smallest = result.summary["smallest_n_per_group"]
    wide[f"n for {target:g}"] = [str(smallest[term]) if smallest[term] is not None else f"> {max(request.n_per_group)}"
                                 for term in wide.index]  # fmt: skip
    click.echo(f"power ({request.method}, {request.source}; alpha {alpha:g}"
               + (f", {sims} {'studies' if simulated else 'data sets'} per n, {result.summary['seconds']:.1f} s"
                  if request.method == "montecarlo"
                  else "; sphericity assumed") + "):")  # fmt: skip
    click.echo(wide.to_string(float_format=lambda v: f"{v:.3f}"))
    click.echo(f"-> {out / 'power.csv'}, {out / 'power-curve.png'}, {out / 'summary.json'}")


COMMANDS = [power]
