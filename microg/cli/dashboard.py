"""``microg dashboard``: the whole study on one page in the browser, live while sessions run."""

from __future__ import annotations

import click

from microg.study.store import open_study

from .common import announce_page, clear_errors, page_certificate, page_options, say_damage, study_dir_argument


@click.command("dashboard")
@study_dir_argument
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address the dashboard listens on; anything but 127.0.0.1 (e.g. the laptop's LAN address, for a "
                   "phone on the lab's Wi-Fi) serves it over HTTPS with the study's certificate (or --cert/--key).")
@click.option("--port", type=click.IntRange(0, 65535), default=0, show_default=True,
              help="Port of the dashboard (0: a free one).")
@page_options
@clear_errors
def dashboard(*, study_dir: str, host: str, port: int, cert: str | None, key: str | None, qr: str | None) -> None:
    """Show the whole of STUDY_DIR on one page, live while sessions run: enrolment against the
    protocol's targets, every participant's sessions (running ones with their phase, task and
    progress), data quality per session, results so far per object and group, questionnaire answers
    received, stations, the store's integrity, links to each session's view and to the last
    export's report.

    It only reads the study (a read-only connection, twice a second, only what is new): it never
    slows a session. The address carries a one-time token; the page is refused to any other site's
    page. Ctrl-C stops it.
    """
    from microg.study.session import handling_stop_signals
    from microg.view.dashboard import Dashboard
    from microg.view.pageserver import PageError, Stopping
    from microg.view.tls import FOLDER

    with open_study(study_dir, readonly=True, accept_damaged=True) as store:
        say_damage(store)
        board = Dashboard(store, host=host, port=port, certificate=page_certificate(store.dir / FOLDER, host, cert, key))
        try:
            try:
                board.start()
            except PageError as error:
                raise click.ClickException(str(error)) from None
            stopping = Stopping()
            with handling_stop_signals(stopping.handle):  # before the announcement: a signal then stops it cleanly
                announce_page(board.server, qr, label="dashboard")
                click.echo("Ctrl-C stops it")
                while not stopping.wait(0.25):
                    pass
        except KeyboardInterrupt:  # a second Ctrl-C
            pass
        finally:
            board.close()
    click.echo("dashboard stopped")


COMMANDS = [dashboard]
