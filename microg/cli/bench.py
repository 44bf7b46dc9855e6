"""``microg bench``: the benchmarks of ``microg.bench`` (accuracy, peers, throughput)."""

from __future__ import annotations

import importlib
from pathlib import Path

import click


def load(name: str):
    """Import ``microg.bench.<name>``, or say which optional engine it needs."""
    try:
        return importlib.import_module(f"microg.bench.{name}")
    except ModuleNotFoundError as error:
        if error.name in ("mujoco", "pybullet"):
            raise click.ClickException(f"`microg bench {name}` needs {error.name}: pip install 'microg[bench]'") from None
        raise


def _options(function):
    function = click.option("--quick", is_flag=True, help="A fast smoke run: fewer points, shorter scenes.")(function)
    function = click.option("--figures", type=click.Path(file_okay=False, path_type=Path),
                            default=Path("bench-results"), show_default=True,
                            help="Directory for the charts (bench-*.png).")(function)
    function = click.option("--out", type=click.Path(file_okay=False, path_type=Path),
                            default=Path("bench-results"), show_default=True,
                            help="Directory for the CSV files.")(function)
    return function


@click.group()
def bench() -> None:
    """Benchmarks: what accuracy costs, the peers beside us, throughput. Not part of the tests."""


@bench.command()
@_options
def accuracy(out: Path, figures: Path, quick: bool) -> None:
    """Error against cost over dt, angular integrators and filter windows (accuracy.csv, bench-accuracy.png)."""
    table = load("accuracy").run(out, figures, quick)
    click.echo(f"{len(table)} measurements -> {out / 'accuracy.csv'}, {figures / 'bench-accuracy.png'}")


@bench.command()
@_options
def peers(out: Path, figures: Path, quick: bool) -> None:
    """The same scenes in MuJoCo and PyBullet in one run: errors and per-step time as ratios (peers.csv)."""
    module = load("peers")
    table, ratios = module.run(out, figures, quick)
    click.echo(ratios.to_string(index=False))
    click.echo(f"-> {out / 'peers.csv'}, {out / 'peer_ratios.csv'}, {figures / 'bench-peers.png'}")


@bench.command()
@_options
@click.option("--participants", type=int, default=None, help="Batch size for the simulated-participant batch.")
def throughput(out: Path, figures: Path, quick: bool, participants: int | None) -> None:
    """Steps per second of the live scene, batches of simulated participants, memory per participant."""
    table = load("throughput").run(out, figures, quick, participants)
    click.echo(table.to_string(index=False))
    click.echo(f"-> {out / 'throughput.csv'}, {figures / 'bench-throughput.png'}")


COMMANDS = [bench]
