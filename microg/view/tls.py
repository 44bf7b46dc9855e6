"""HTTPS for the participant's page away from 127.0.0.1: a certificate microg makes for a study, or the lab's own.

WebXR needs a secure context: a page from ``https://``, or from ``http://`` on the machine itself
(which is how ``adb reverse`` works: the headset's 127.0.0.1 is forwarded to the laptop). A headset
on Wi-Fi reaches the laptop's LAN address, so there the page and its WebSocket are served over TLS.

- ``study_certificate(folder, host)``: the certificate microg keeps in ``folder`` (a study's
  ``tls/``): a self-signed ECDSA P-256 certificate for the addresses it served (``host``, the
  addresses of the one before it, 127.0.0.1 and localhost), valid for ``VALID_DAYS``, its key
  readable by its owner only. It is made when there is none, when it does not cover ``host`` or when
  it expires within ``RENEW_DAYS``; otherwise the same one is used again, so a headset that accepted
  it once is not asked again. The browser warns about it (nobody vouches for it): the participant's
  side checks it by its SHA-256 fingerprint, which the session prints.
- ``lab_certificate(cert, key, host)``: a certificate the lab made (for instance with mkcert, its
  root installed on the headset, so there is no warning at all), checked before it is served: PEM
  files that load, the key its own, ``host`` among its names, not expired.

Either way the page keeps its one-time token and its Origin and Host checks (``display``).
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import ssl
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

LOCALHOST = "127.0.0.1"
"""The one address the participant's page is served on over plain HTTP, without a token."""
FOLDER = "tls"
"""A study keeps its certificate in ``<study>/tls/``."""
CERT_FILE, KEY_FILE = "cert.pem", "key.pem"
VALID_DAYS = 397
"""Within the 398 days browsers accept for a server certificate."""
RENEW_DAYS = 30
"""A certificate that expires sooner is made anew."""
ALWAYS = ("127.0.0.1", "localhost")
"""Names every certificate microg makes covers (``adb reverse`` over HTTPS too)."""


class CertificateError(ValueError):
    """A certificate that cannot be served; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Certificate:
    """A certificate and its key to serve the page with; ``note`` says what was made, if anything."""

    cert: Path
    key: Path
    names: tuple[str, ...]
    """The addresses and host names it is valid for."""
    fingerprint: str
    """SHA-256 of the certificate (DER) as browsers show it: ``AB:CD:...``."""
    note: str | None = None

    def context(self) -> ssl.SSLContext:
        """A TLS server context (TLS 1.2 or later) serving this certificate."""
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        context.minimum_version = ssl.TLSVersion.TLSv1_2
        try:
            context.load_cert_chain(self.cert, self.key)
        except (ssl.SSLError, OSError) as error:
            raise CertificateError(f"{self.cert}, {self.key}: cannot serve this certificate and key ({error})") from None
        return context


def fingerprint(certificate) -> str:
    """SHA-256 of a certificate (cryptography's ``x509.Certificate``) as ``AB:CD:...``."""
    return ":".join(f"{b:02X}" for b in certificate.fingerprint(hashes.SHA256()))


def names_of(certificate) -> tuple[str, ...]:
    """The IP addresses and DNS names of a certificate's subject alternative names."""
    try:
        names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return ()
    return tuple(str(ip) for ip in names.get_values_for_type(x509.IPAddress)) + tuple(
        names.get_values_for_type(x509.DNSName))


def covers(names: tuple[str, ...], host: str) -> bool:
    """Whether a certificate for ``names`` is valid for ``host`` (an address, or a host name,
    ``*.lab.example`` matching one label)."""
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        host = host.lower()
        return any(n.lower() == host or (n.startswith("*.") and host.split(".", 1)[-1] == n[2:].lower()
                                         and "." in host) for n in names)
    return any(_same_address(n, address) for n in names)


def _same_address(name: str, address) -> bool:
    try:
        return ipaddress.ip_address(name) == address
    except ValueError:
        return False


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.timezone.utc)


def study_certificate(folder: str | Path, host: str) -> Certificate:
    """The certificate in ``folder`` for ``host``, made or made anew when needed (module docstring)."""
    folder = Path(folder)
    cert, key = folder / CERT_FILE, folder / KEY_FILE
    earlier: tuple[str, ...] = ()
    existing = None
    why = f"made a certificate for {host} in {folder}"
    if cert.exists() and key.exists():
        try:
            existing = x509.load_pem_x509_certificate(cert.read_bytes())
            private = _private_key(key)
        except (ValueError, OSError):
            existing, why = None, f"made a new certificate in {folder}: the one there could not be read"
        else:
            if not _pair(existing, private):
                existing, why = None, f"made a new certificate in {folder}: {KEY_FILE} there was not its key"
        if existing is not None:
            earlier = names_of(existing)
            expires = existing.not_valid_after_utc
            if covers(earlier, host) and expires - _now() > datetime.timedelta(days=RENEW_DAYS):
                return Certificate(cert, key, earlier, fingerprint(existing))
            why = (f"made a new certificate in {folder}: the earlier one " +
                   (f"did not cover {host}" if not covers(earlier, host) else f"expires on {expires:%Y-%m-%d}"))
    names = tuple(dict.fromkeys([host, *earlier, *ALWAYS]))
    made = _make(names)
    _write(folder, made)
    return Certificate(cert, key, names, fingerprint(made[0]), note=f"{why} (valid for {', '.join(names)})")


def _make(names: tuple[str, ...]):
    """(certificate, key) self-signed for ``names``, valid ``VALID_DAYS`` from now."""
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"microg participant page ({names[0]})")])
    alternatives = []
    for name in names:
        try:
            alternatives.append(x509.IPAddress(ipaddress.ip_address(name)))
        except ValueError:
            alternatives.append(x509.DNSName(name))
    now = _now()
    certificate = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject).public_key(key.public_key())
                   .serial_number(x509.random_serial_number())
                   .not_valid_before(now - datetime.timedelta(minutes=5))
                   .not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
                   .add_extension(x509.SubjectAlternativeName(alternatives), critical=False)
                   .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                   .add_extension(x509.KeyUsage(digital_signature=True, key_encipherment=False, content_commitment=False,
                                                data_encipherment=False, key_agreement=False, key_cert_sign=False,
                                                crl_sign=False, encipher_only=False, decipher_only=False), critical=True)
                   .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
                   .sign(key, hashes.SHA256()))
    return certificate, key


def _write(folder: Path, made) -> None:
    """Write the pair into ``folder``, each file whole (a scratch file renamed), the key for its owner only."""
    certificate, key = made
    folder.mkdir(parents=True, exist_ok=True)
    files = ((KEY_FILE, key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                          serialization.NoEncryption()), 0o600),
             (CERT_FILE, certificate.public_bytes(serialization.Encoding.PEM), 0o644))
    for name, data, mode in files:
        scratch = folder / f".{name}.{os.getpid()}"
        descriptor = os.open(scratch, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
        with os.fdopen(descriptor, "wb") as out:
            out.write(data)
        os.replace(scratch, folder / name)


def lab_certificate(cert: str | Path, key: str | Path, host: str) -> Certificate:
    """The lab's own certificate and key, checked for ``host`` (module docstring)."""
    cert, key = Path(cert), Path(key)
    try:
        certificate = x509.load_pem_x509_certificate(cert.read_bytes())
    except (ValueError, OSError) as error:
        raise CertificateError(f"--cert {cert}: not a readable PEM certificate ({error})") from None
    try:
        private = _private_key(key)
    except (ValueError, OSError) as error:
        raise CertificateError(f"--key {key}: {error}") from None
    if not _pair(certificate, private):
        raise CertificateError(f"--key {key} is not the key of --cert {cert}")
    names = names_of(certificate)
    if not covers(names, host):
        raise CertificateError(f"--cert {cert} is for {', '.join(names) or 'no address'}, not for --host {host}: the "
                               f"browser would refuse it; make one that names {host} (e.g. mkcert {host})")
    if certificate.not_valid_after_utc <= _now():
        raise CertificateError(f"--cert {cert} expired on {certificate.not_valid_after_utc:%Y-%m-%d}")
    if certificate.not_valid_before_utc > _now():
        raise CertificateError(f"--cert {cert} is valid only from {certificate.not_valid_before_utc:%Y-%m-%d %H:%M} "
                               "UTC: the browser would refuse it (is this machine's clock right?)")
    return Certificate(cert, key, names, fingerprint(certificate))


def _private_key(key: Path):
    """The private key in the PEM file ``key``; ValueError saying why it cannot be read."""
    try:
        return serialization.load_pem_private_key(key.read_bytes(), password=None)
    except (ValueError, TypeError) as error:
        raise ValueError(f"not a readable PEM private key without a passphrase ({error})") from None


def _pair(certificate, private) -> bool:
    """Whether ``private`` is the key of ``certificate``."""
    spki = serialization.PublicFormat.SubjectPublicKeyInfo
    return (private.public_key().public_bytes(serialization.Encoding.DER, spki)
            == certificate.public_key().public_bytes(serialization.Encoding.DER, spki))
