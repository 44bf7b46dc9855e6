"""What the study verbs share: turning the study's errors into clear command-line errors."""

from __future__ import annotations

import functools

import click

from microg.study.assignment import ParticipantError
from microg.study.framelog import DamagedFramesError
from microg.study.inputs import InputError
from microg.study.protocol import ProtocolError
from microg.study.questionnaire import RatingError
from microg.study.store import StoreError
from microg.study.xdf import XdfError

COMMANDS: list = []
EXPECTED = (ProtocolError, ParticipantError, StoreError, DamagedFramesError, InputError, RatingError, XdfError,
            FileExistsError, FileNotFoundError)

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


def picture_size(text: str) -> tuple[int, int]:
    """``--size WIDTHxHEIGHT`` in pixels (at least 16 each way)."""
    width, _, height = text.partition("x")
    if not (width.isdigit() and height.isdigit() and int(width) >= 16 and int(height) >= 16):
        raise click.BadParameter(f"{text!r}: give WIDTHxHEIGHT in pixels, e.g. 480x360", param_hint="--size")
    return int(width), int(height)
