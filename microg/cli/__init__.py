"""The ``microg`` command. Each module in this package holds one verb (or group of verbs) and
lists its click commands in ``COMMANDS``; they are attached to the root group here."""

from __future__ import annotations

import importlib
import pkgutil

import click

from microg import __version__

from .common import system_error


class _Microg(click.Group):
    """The root group: a file operation that fails (a folder that may not be entered, a full disk)
    ends any verb with a message naming the file, not a traceback."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except OSError as error:
            if error.filename is None:
                raise
            raise click.ClickException(system_error(error)) from None


@click.group(cls=_Microg, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="microg")
def main() -> None:
    """Run, log and analyse user studies of hand-object interaction in simulated microgravity."""


for _module in pkgutil.iter_modules(__path__):
    for _command in importlib.import_module(f"{__name__}.{_module.name}").COMMANDS:
        main.add_command(_command)
