"""What the study verbs share: turning the study's errors into clear command-line errors."""

from __future__ import annotations

import functools

import click

from microg.study.assignment import ParticipantError
from microg.study.inputs import InputError
from microg.study.protocol import ProtocolError
from microg.study.questionnaire import RatingError
from microg.study.store import StoreError

COMMANDS: list = []
EXPECTED = (ProtocolError, ParticipantError, StoreError, InputError, RatingError, FileExistsError,
            FileNotFoundError)

study_dir_argument = click.argument("study_dir", type=click.Path(file_okay=False, path_type=str))


def clear_errors(command):
    """Report the study's own errors as ``Error: <message>`` (exit status 1), without a traceback."""
    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except EXPECTED as error:
            raise click.ClickException(str(error)) from None
    return wrapper
