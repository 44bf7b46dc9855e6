"""What the verbs share: the study's errors and the system's (a folder that may not be entered, a
full disk) as clear command-line errors, paths that must exist, the old spellings of renamed
options, and how the participant's page is served and announced (its certificate, its address as
text and QR code)."""

from __future__ import annotations

import functools
import getpass
import os
from pathlib import Path

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


def clear_errors(command):
    """Report the study's own errors as ``Error: <message>`` (exit status 1), without a traceback."""
    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except EXPECTED as error:
            raise click.ClickException(str(error)) from None
    return wrapper


def say_damage(store) -> None:
    """What a verb that reads a study says of the damage the check on open found in it
    (``Store.problems``), each problem on a warning line, then how to see it whole."""
    for problem in store.problems:
        click.echo(f"warning: the study is damaged: {problem}", err=True)
    if store.problems:
        click.echo(f"warning: see the full check with: microg study check {store.dir}", err=True)


EFFECTIVE_IDS = os.access in os.supports_effective_ids
"""Whether permissions can be checked for the user the process acts as (POSIX), not the one who started it."""


def _user() -> str:
    """The name of the user the process acts as."""
    try:
        import pwd

        return pwd.getpwuid(os.geteuid()).pw_name
    except (ImportError, KeyError):
        return getpass.getuser()


def system_error(error: OSError) -> str:
    """What a failed file operation means, naming the file: for a permission, the folder that may not
    be entered or the file or folder that may not be read or written, and by whom."""
    if not isinstance(error, PermissionError):
        return f"{error.filename}: {error.strerror or error}"
    path = Path(os.path.abspath(error.filename))
    user = f"user {_user()}"
    for folder in reversed(path.parents):
        if folder.is_dir() and not os.access(folder, os.X_OK, effective_ids=EFFECTIVE_IDS):
            return f"{folder}: permission denied: {user} may not enter this folder (to reach {error.filename})"
    if path.exists():
        return f"{error.filename}: permission denied: {user} may not {'open' if path.is_dir() else 'read or write'} it"
    return f"{error.filename}: permission denied: {user} may not create it in {path.parent}"


class ExistingPath(click.Path):
    """``click.Path(exists=True)`` that tells a path it may not look at from a missing one."""

    def __init__(self, **kwargs):
        super().__init__(exists=True, **kwargs)

    def convert(self, value, param, ctx):
        try:
            os.stat(value)
        except PermissionError as error:
            self.fail(system_error(error), param, ctx)
        except (OSError, ValueError):
            pass  # click says what is wrong with it
        return super().convert(value, param, ctx)


study_dir_argument = click.argument("study_dir", type=click.Path(file_okay=False, path_type=str))
SEED = click.IntRange(0, 2**63 - 1)
"""A seed: a whole number the study database stores (SQLite integers are 64-bit)."""


def renamed(old: str, new: str, *, flag: bool = False):
    """A hidden option for the old spelling of a renamed one: given, it says what it became."""
    def refuse(ctx: click.Context, param: click.Parameter, value) -> None:
        if value if flag else value is not None:
            raise click.UsageError(f"{old} is now {new}", ctx)

    return click.option(old, f"renamed_{old.lstrip('-').replace('-', '_')}", is_flag=flag, hidden=True,
                        expose_value=False, callback=refuse)


def picture_size(text: str) -> tuple[int, int]:
    """``--size WIDTHxHEIGHT`` in pixels (at least 16 each way)."""
    width, _, height = text.partition("x")
    if not (width.isdigit() and height.isdigit() and int(width) >= 16 and int(height) >= 16):
        raise click.BadParameter(f"{text!r}: give WIDTHxHEIGHT in pixels, e.g. 480x360", param_hint="--size")
    return int(width), int(height)


PAGE_OPTIONS = [
    click.option("--cert", type=click.Path(dir_okay=False, exists=True, path_type=str), default=None,
                 help="The lab's own certificate (PEM) for the page over HTTPS, e.g. made with mkcert "
                      "for the --host address; with --key. Default away from 127.0.0.1: a certificate microg makes "
                      "and keeps (a session's in STUDY/tls/, hands record's in the user's cache folder), its "
                      "SHA-256 printed."),
    click.option("--key", type=click.Path(dir_okay=False, exists=True, path_type=str), default=None,
                 help="The private key (PEM, no passphrase) of --cert."),
    click.option("--qr", type=click.Path(dir_okay=False, path_type=str), default=None,
                 help="Also write the page's address (with its token) as a QR code into this PNG file; the terminal "
                      "shows the code in any case."),
]
"""``--cert``, ``--key`` and ``--qr``: how a page (the participant's, the dashboard) is served and announced."""


def page_options(command):
    """Give ``command`` the ``PAGE_OPTIONS``."""
    for option in reversed(PAGE_OPTIONS):
        command = option(command)
    return command


def page_certificate(folder: Path, host: str, cert: str | None, key: str | None):
    """The certificate a page is served with (``microg.view.tls``): the lab's own
    (``cert``, ``key``), else away from 127.0.0.1 the one microg keeps in ``folder``; None (plain
    HTTP) on 127.0.0.1 without ``cert``."""
    from microg.view.tls import LOCALHOST, CertificateError, lab_certificate, study_certificate

    if (cert is None) != (key is None):
        raise click.UsageError("give --cert FILE and --key FILE together")
    try:
        if cert is not None:
            certificate = lab_certificate(cert, key, host)
        elif host == LOCALHOST:
            return None
        else:
            certificate = study_certificate(folder, host)
        certificate.context()
    except (CertificateError, OSError) as error:
        raise click.ClickException(str(error)) from None
    return certificate


def announce_page(page, qr_file: str | None = None, label: str = "participant view") -> None:
    """Print where a page is (``label``: its address with the token, as text and as a QR code to
    scan), how to check its certificate, and write the code into ``qr_file``."""
    from microg.view.qr import terminal_code, write_code

    click.echo(f"{label}: {page.url}")
    certificate = page.certificate
    if certificate is not None:
        if certificate.note:
            click.echo(f"  {certificate.note}")
        click.echo(f"  HTTPS certificate SHA-256 {certificate.fingerprint}")
        click.echo("  (a browser that warns about it shows this fingerprint in the certificate's details: go on only "
                   "if it is this one)")
    if page.token:
        click.echo(f"  (one-time token {page.token}: the address above carries it; the page refuses to connect "
                   "without it)")
    click.echo(terminal_code(page.url), nl=False)
    if qr_file is not None:
        try:
            write_code(page.url, qr_file)
        except (OSError, ValueError) as error:
            raise click.ClickException(f"--qr {qr_file}: cannot write the QR code ({error})") from None
        click.echo(f"  QR code of the address: {qr_file}")
