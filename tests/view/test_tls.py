"""The participant's page away from 127.0.0.1: served over HTTPS with the certificate microg makes for
the study (Chromium accepts it by its fingerprint only) or with the lab's own; the token, Origin and
Host checks hold over TLS; the printed address comes back from its QR code through a decoder."""

from __future__ import annotations

import asyncio
import base64
import datetime
import hashlib
import ipaddress
import os
import sqlite3
import ssl
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID
from PIL import Image

from microg.study.protocol import Phase, load_protocol
from microg.view.display import ParticipantDisplay
from microg.view.tls import CertificateError, lab_certificate, study_certificate

from tests.study.conftest import PROTOCOLS

from .browser import MISSING, chromium, page_text
from .conftest import new_study

needs_browser = pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium "
                                                         "chromium-driver; pip install selenium)")
ROOT = Path(__file__).resolve().parents[2]
LAN = "127.0.0.2"
"""A loopback address that is not 127.0.0.1: the page's rules for the LAN apply, no traffic leaves the machine."""
WORK_S = 120.0
"""A generous bound for a page, a handshake or the session's first lines on a loaded machine."""
QUARTERS = {"█": (1, 1), "▀": (1, 0), "▄": (0, 1), " ": (0, 0)}
"""A terminal character of the code: (top module light, bottom module light)."""


def decoded(image: Image.Image) -> list[str]:
    """The texts of the QR codes a decoder (zxing-cpp) finds in ``image``, read as drawn (not inverted)."""
    import zxingcpp

    return [code.text for code in zxingcpp.read_barcodes(image.convert("L"), try_invert=False)]


def terminal_picture(lines: list[str], scale: int = 8) -> Image.Image:
    """The code the terminal shows (half blocks, light modules in the text's colour) as a picture,
    light on a light margin as the terminal shows it on a dark background read as light."""
    width = max(len(line) for line in lines)
    light = np.zeros((2 * len(lines), width), dtype=bool)
    for row, line in enumerate(lines):
        for column, character in enumerate(line.ljust(width)):
            light[2 * row, column], light[2 * row + 1, column] = QUARTERS[character]
    pixels = np.pad(light, 4, constant_values=True).astype(np.uint8) * 255
    return Image.fromarray(pixels).resize((pixels.shape[1] * scale, pixels.shape[0] * scale), Image.NEAREST)


def spki_hash(certificate_file: Path) -> str:
    """Base64 SHA-256 of a certificate's public key (SubjectPublicKeyInfo): what Chromium's
    --ignore-certificate-errors-spki-list takes."""
    certificate = x509.load_pem_x509_certificate(certificate_file.read_bytes())
    spki = certificate.public_key().public_bytes(serialization.Encoding.DER,
                                                 serialization.PublicFormat.SubjectPublicKeyInfo)
    return base64.b64encode(hashlib.sha256(spki).digest()).decode()


def presented(port: int) -> bytes:
    """The certificate (DER) the server on LAN:``port`` presents in a TLS handshake."""
    context = ssl.create_default_context()
    context.check_hostname, context.verify_mode = False, ssl.CERT_NONE

    async def handshake() -> bytes:
        reader, writer = await asyncio.wait_for(asyncio.open_connection(LAN, port, ssl=context), WORK_S)
        der = writer.get_extra_info("ssl_object").getpeercert(binary_form=True)
        writer.close()
        return der

    return asyncio.run(handshake())


def colons(digest: bytes) -> str:
    return ":".join(f"{b:02X}" for b in digest)


def answer(url: str, origin: str, context: ssl.SSLContext) -> int:
    """The HTTP status the server answers a WebSocket handshake from a page of ``origin`` with
    (101: it connected)."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    async def attempt() -> int:
        try:
            async with connect(url, origin=origin, ssl=context, open_timeout=WORK_S):
                return 101
        except InvalidStatus as error:
            return error.response.status_code

    return asyncio.run(attempt())


def authority(folder: Path, names: list[str]) -> tuple[Path, Path, Path]:
    """A lab's own certificates as mkcert makes them: a root (its file returned first, to trust) and
    a certificate it signs for ``names`` with its key."""
    now = datetime.datetime.now(datetime.timezone.utc)
    root_key, leaf_key = ec.generate_private_key(ec.SECP256R1()), ec.generate_private_key(ec.SECP256R1())
    root_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "test lab root")])
    root = (x509.CertificateBuilder().subject_name(root_name).issuer_name(root_name)
            .public_key(root_key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(days=1)).not_valid_after(now + datetime.timedelta(days=30))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(x509.KeyUsage(digital_signature=True, key_cert_sign=True, crl_sign=True,
                                         content_commitment=False, key_encipherment=False, data_encipherment=False,
                                         key_agreement=False, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(root_key.public_key()), critical=False)
            .sign(root_key, hashes.SHA256()))
    leaf = (x509.CertificateBuilder().subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, names[0])]))
            .issuer_name(root_name).public_key(leaf_key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(days=1)).not_valid_after(now + datetime.timedelta(days=30))
            .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address(n)) for n in names]),
                           critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(root_key.public_key()), critical=False)
            .sign(root_key, hashes.SHA256()))
    folder.mkdir(parents=True, exist_ok=True)
    files = folder / "root.pem", folder / "lab.pem", folder / "lab-key.pem"
    files[0].write_bytes(root.public_bytes(serialization.Encoding.PEM))
    files[1].write_bytes(leaf.public_bytes(serialization.Encoding.PEM))
    files[2].write_bytes(leaf_key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                                serialization.NoEncryption()))
    return files


@pytest.mark.slow
def test_a_session_on_the_lan_prints_its_https_address_fingerprint_and_qr_code(tmp_path):
    """The real command: the printed fingerprint is the certificate's the server presents, and the
    terminal's code and the --qr picture both decode to the printed address with its token."""
    study = new_study(tmp_path / "study")
    child = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "session", "run", str(study), "--participant", "P01",
                              "--input", "webxr", "--host", LAN, "--qr", str(tmp_path / "code.png"), "--quiet"],
                             cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    lines: list[str] = []
    try:
        for line in child.stdout:  # the session then waits at the researcher's first prompt: nothing is raced
            lines.append(line.rstrip("\n"))
            if line.startswith("=="):
                break
        else:
            pytest.fail("the session ended before its first phase:\n" + "\n".join(lines))
        port = int(next(line for line in lines if line.startswith("participant view: ")).split(":")[3].split("/")[0])
        der = presented(port)
    finally:
        child.kill()
        child.wait(timeout=WORK_S)
    url = next(line for line in lines if line.startswith("participant view: ")).removeprefix("participant view: ")
    assert url.startswith(f"https://{LAN}:{port}/?token=")
    printed = next(line for line in lines if "HTTPS certificate SHA-256" in line).split()[-1]
    assert printed == colons(hashlib.sha256(der).digest())
    stored = x509.load_pem_x509_certificate((study / "tls" / "cert.pem").read_bytes())
    assert printed == colons(stored.fingerprint(hashes.SHA256()))
    assert stat.S_IMODE((study / "tls" / "key.pem").stat().st_mode) == 0o600

    code = [line for line in lines if line and set(line) <= set(QUARTERS)]
    assert len(code) > 10
    assert decoded(terminal_picture(code)) == [url]
    assert decoded(Image.open(tmp_path / "code.png")) == [url]


@needs_browser
def test_chromium_opens_the_page_over_https_accepting_the_certificate_by_its_fingerprint_only(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    certificate = study_certificate(tmp_path / "tls", LAN)
    other = study_certificate(tmp_path / "other", LAN)
    with ParticipantDisplay(protocol, host=LAN, certificate=certificate) as display:
        display.phase(Phase("orientation", 1.0, "Reached over TLS."))
        with chromium((800, 600), (f"--ignore-certificate-errors-spki-list={spki_hash(other.cert)}",)) as driver:
            driver.set_page_load_timeout(WORK_S)
            driver.get(display.url)
            assert "Your connection is not private" in page_text(driver)
            assert display.connected == 0
        with chromium((800, 600), (f"--ignore-certificate-errors-spki-list={spki_hash(certificate.cert)}",)) as driver:
            from selenium.webdriver.support.ui import WebDriverWait

            driver.set_page_load_timeout(WORK_S)
            driver.get(display.url)
            WebDriverWait(driver, WORK_S).until(lambda d: "Reached over TLS." in page_text(d))
            assert driver.execute_script("return location.protocol + window.isSecureContext") == "https:true"
            assert display.connected == 1


def test_over_tls_the_websocket_refuses_a_wrong_token_and_a_foreign_origin(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    certificate = study_certificate(tmp_path / "tls", LAN)
    trusting = ssl.create_default_context(cafile=str(certificate.cert))
    with ParticipantDisplay(protocol, host=LAN, certificate=certificate) as display:
        assert display.url == f"https://{LAN}:{display.port}/?token={display.token}"
        ws, own = f"wss://{LAN}:{display.port}/ws", f"https://{LAN}:{display.port}"
        assert answer(ws, own, trusting) == 403
        assert answer(f"{ws}?token=guess", own, trusting) == 403
        assert answer(f"{ws}?token={display.token}", "https://evil.example", trusting) == 403
        assert answer(f"{ws}?token={display.token}", f"http://{LAN}:{display.port}", trusting) == 403
        assert answer(f"{ws}?token={display.token}", own, trusting) == 101
        with pytest.raises(ssl.SSLCertVerificationError):
            answer(f"{ws}?token={display.token}", own, ssl.create_default_context())


def test_the_labs_own_certificate_is_served_and_verified_through_its_root(tmp_path):
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    root, cert, key = authority(tmp_path / "lab", [LAN])
    certificate = lab_certificate(cert, key, LAN)
    with ParticipantDisplay(protocol, host=LAN, certificate=certificate) as display:
        trusting_the_root = ssl.create_default_context(cafile=str(root))  # checks the chain and the address
        own = f"https://{LAN}:{display.port}"
        assert answer(f"wss://{LAN}:{display.port}/ws?token={display.token}", own, trusting_the_root) == 101
        assert presented(display.port) == x509.load_pem_x509_certificate(cert.read_bytes()).public_bytes(
            serialization.Encoding.DER)

    _, elsewhere, elsewhere_key = authority(tmp_path / "elsewhere", ["192.0.2.7"])
    with pytest.raises(CertificateError, match=f"is for 192.0.2.7, not for --host {LAN}: the browser would refuse"):
        lab_certificate(elsewhere, elsewhere_key, LAN)
    with pytest.raises(CertificateError, match=f"--key {elsewhere_key} is not the key of --cert {cert}"):
        lab_certificate(cert, elsewhere_key, LAN)
    with pytest.raises(CertificateError, match=f"--key {cert}: not a readable PEM private key"):
        lab_certificate(cert, cert, LAN)


def test_the_studys_certificate_is_kept_and_made_anew_only_for_an_address_it_does_not_cover(tmp_path):
    first = study_certificate(tmp_path, LAN)
    assert first.note.startswith(f"made a certificate for {LAN}") and set(first.names) == {LAN, "127.0.0.1",
                                                                                          "localhost"}
    again = study_certificate(tmp_path, LAN)
    assert (again.fingerprint, again.note) == (first.fingerprint, None)
    moved = study_certificate(tmp_path, "192.0.2.7")  # the laptop on another network: no traffic is sent there
    assert "the earlier one did not cover 192.0.2.7" in moved.note and moved.fingerprint != first.fingerprint
    assert {LAN, "192.0.2.7"} <= set(moved.names)
    assert study_certificate(tmp_path, LAN).fingerprint == moved.fingerprint
    with pytest.raises(ValueError, match="give it a certificate"):
        ParticipantDisplay(load_protocol(PROTOCOLS / "tiny.toml"), host=LAN)


def started_or_refused(display: ParticipantDisplay):
    """What ``display.start()`` did, in a thread the test waits for with a bound: "started", or the error."""
    import threading

    from tests.waiting import joined

    outcome = []

    def start():
        try:
            display.start()
            outcome.append("started")
        except Exception as error:  # noqa: BLE001 (the test looks at it)
            outcome.append(error)

    thread = threading.Thread(target=start, daemon=True)
    thread.start()
    joined(thread, "the participant page's server to start or refuse")
    return outcome[0]


def test_a_page_address_or_port_that_cannot_be_had_is_refused_not_waited_for(tmp_path):
    """A --port another program serves, a --host that is not this machine's: the page says so
    (before this, the session waited for the server's start for ever)."""
    import socket

    from microg.view.pageserver import PageError

    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        refused = started_or_refused(ParticipantDisplay(protocol, port=port))
        assert isinstance(refused, PageError)
        assert str(refused).startswith(f"cannot serve the participant's page at 127.0.0.1:{port} (Address already "
                                       "in use): another program serves port")
    elsewhere = "192.0.2.7"  # TEST-NET-1: never an address of this machine; nothing is sent anywhere
    refused = started_or_refused(ParticipantDisplay(protocol, host=elsewhere,
                                                    certificate=study_certificate(tmp_path / "tls", elsewhere)))
    assert isinstance(refused, PageError) and f"{elsewhere} is not an address of this machine" in str(refused)


def test_connections_that_end_before_speaking_http_leave_no_traceback(tmp_path, capsys, monkeypatch):
    """A browser's unused preconnection, a request cut off, garbage over TLS: the server logs them,
    its log drops them (they would print tracebacks into the session's terminal), the page works on."""
    import socket
    import threading

    from microg.view import pageserver
    from tests.waiting import wait_until

    seen, lock = [], threading.Lock()
    drop = pageserver.HANDSHAKES.filter

    def noting(record):
        kept = drop(record)
        with lock:
            seen.append((record.getMessage(), kept))
        return kept

    monkeypatch.setattr(pageserver.HANDSHAKES, "filter", noting)
    protocol = load_protocol(PROTOCOLS / "tiny.toml")
    certificate = study_certificate(tmp_path / "tls", LAN)
    context = ssl.create_default_context(cafile=str(certificate.cert))
    with ParticipantDisplay(protocol, host=LAN, certificate=certificate) as display:
        for payload in (b"", b"GET / HTT", b"\x00\xff" * 600):
            with socket.create_connection((LAN, display.port), timeout=WORK_S) as raw:
                with context.wrap_socket(raw, server_hostname=LAN) as tls:
                    tls.sendall(payload)
        with socket.create_connection(("127.0.0.2", display.port), timeout=WORK_S):
            pass  # a connection closed before its TLS handshake
        wait_until(lambda: len(seen) >= 3, "the server's records of the three connections that spoke no HTTP",
                   seen=lambda: seen, timeout=WORK_S)
        own = f"https://{LAN}:{display.port}"
        assert answer(f"wss://{LAN}:{display.port}/ws?token={display.token}", own, context) == 101
    assert all(not kept for _, kept in seen), seen
    assert "Traceback" not in capsys.readouterr().err


def test_a_broken_key_of_the_studys_certificate_is_made_anew_and_a_labs_certificate_not_yet_valid_is_refused(
        tmp_path):
    first = study_certificate(tmp_path, LAN)
    (tmp_path / "key.pem").write_text("-----BEGIN PRIVATE KEY-----\nbroken\n-----END PRIVATE KEY-----\n")
    again = study_certificate(tmp_path, LAN)
    assert again.note.startswith(f"made a new certificate in {tmp_path}: the one there could not be read")
    again.context()  # it serves
    other = study_certificate(tmp_path / "other", LAN)
    (tmp_path / "key.pem").write_bytes((tmp_path / "other" / "key.pem").read_bytes())  # another pair's key
    third = study_certificate(tmp_path, LAN)
    assert third.note.startswith(f"made a new certificate in {tmp_path}: key.pem there was not its key")
    assert len({first.fingerprint, again.fingerprint, third.fingerprint, other.fingerprint}) == 4
    third.context()

    _, cert, key = authority(tmp_path / "lab", [LAN])
    key_object = serialization.load_pem_private_key(key.read_bytes(), password=None)
    later = datetime.datetime.now(datetime.timezone.utc) + datetime.timedelta(days=2)
    issued = x509.load_pem_x509_certificate(cert.read_bytes())
    early = (x509.CertificateBuilder().subject_name(issued.subject).issuer_name(issued.subject)
             .public_key(key_object.public_key()).serial_number(x509.random_serial_number())
             .not_valid_before(later).not_valid_after(later + datetime.timedelta(days=30))
             .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address(LAN))]), critical=False)
             .sign(key_object, hashes.SHA256()))
    cert.write_bytes(early.public_bytes(serialization.Encoding.PEM))
    with pytest.raises(CertificateError, match=f"--cert {cert} is valid only from .* UTC: the browser would refuse"):
        lab_certificate(cert, key, LAN)


def test_a_session_whose_page_cannot_be_served_there_says_so_and_writes_nothing(tmp_path):
    import socket

    from tests.waiting import ended

    study = new_study(tmp_path / "study")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        child = subprocess.Popen([sys.executable, "-c", "from microg.cli import main; main()", "session", "run",
                                  str(study), "--participant", "P01", "--input", "webxr", "--port", str(port),
                                  "--quiet"], cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True)
        assert ended(child, "the session refusing the taken port") == 1
        said = child.stdout.read()
    assert "Traceback" not in said and f"Error: cannot serve the participant's page at 127.0.0.1:{port}" in said
    assert "another program serves port" in said
    with sqlite3.connect(f"file:{study / 'study.db'}?mode=ro", uri=True) as db:
        assert db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0] == 0
    db.close()
