"""Authenticated, encrypted streams: CurveZMQ keys, the publisher's authenticator, options.

CurveZMQ (RFC 26, ``zmq.auth``) gives each peer a long-term key pair. The publisher proves
it holds the secret key matching the public key its subscribers were given (so a subscriber
cannot be fooled by an impostor), every message is encrypted, and the publisher's ZAP
handler (:class:`zmq.auth.thread.ThreadAuthenticator`) lets in only subscribers whose public
key is in an authorised directory: an unknown subscriber's handshake fails and it receives
nothing. docs/protocol.md ("Security") gives the threat model and the commands.

For other front ends (``shipradar view``, scripts): :func:`add_curve_arguments` adds the
``--curve-*`` options to an :mod:`argparse` parser and :func:`curve_from_args` turns the
parsed options into a :class:`CurveServer` (publishers) or :class:`CurveClient`
(subscribers), whose :meth:`CurveClient.apply` configures a SUB socket before it connects.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shipradar.sim.world.errors import BadInputError

__all__ = [
    "MAX_KEY_FILE_BYTES",
    "CurveClient",
    "CurveKeyError",
    "CurveServer",
    "add_curve_arguments",
    "curve_from_args",
    "generate_keys",
]

#: Largest key (certificate) file accepted [bytes]; zmq's are about 300 bytes.
MAX_KEY_FILE_BYTES: int = 64 * 1024
#: Most public keys read from an authorised-keys directory.
MAX_AUTHORIZED_KEYS: int = 10_000
#: Length of a Z85-encoded 32-byte CURVE key [characters].
_Z85_KEY_LEN = 40


class CurveKeyError(ValueError, BadInputError):
    """A key file or key directory that cannot be used (message names the option and file)."""


def _load_key(path: str | os.PathLike[str], option: str, *, secret: bool) -> tuple[bytes, bytes]:
    """(public, secret) Z85 keys of a zmq certificate file; secret is b"" when not needed."""
    import zmq
    import zmq.auth

    p = Path(path)
    try:
        size = p.stat().st_size
    except OSError as exc:
        raise CurveKeyError(f"{option}: cannot read {p} ({exc.strerror})") from None
    if not p.is_file():
        raise CurveKeyError(f"{option}: {p} is not a file")
    if size > MAX_KEY_FILE_BYTES:
        raise CurveKeyError(
            f"{option}: {p} is {size} bytes, must be <= {MAX_KEY_FILE_BYTES} (a key file)")
    try:
        public, secret_key = zmq.auth.load_certificate(p)
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise CurveKeyError(f"{option}: {p} is not a CURVE key file ({exc})") from None
    for name, key in (("public", public), ("secret", secret_key)):
        if key is None:
            continue
        if len(key) != _Z85_KEY_LEN:
            raise CurveKeyError(f"{option}: {p} holds a {name} key of {len(key)} characters, "
                                f"must be {_Z85_KEY_LEN} (Z85)")
        try:
            zmq.utils.z85.decode(key)
        except (ValueError, KeyError, IndexError):
            raise CurveKeyError(f"{option}: {p} holds a {name} key that is not Z85") from None
    if secret and secret_key is None:
        raise CurveKeyError(
            f"{option}: {p} holds no secret key; give the .key_secret file "
            f"(shipradar keys generate DIR writes both)")
    return public, secret_key or b""


def _authorized_keys(directory: str | os.PathLike[str], option: str) -> list[bytes]:
    d = Path(directory)
    if not d.is_dir():
        raise CurveKeyError(f"{option}: {d} is not a directory of public keys (*.key)")
    files = sorted(d.glob("*.key"))
    if not files:
        raise CurveKeyError(f"{option}: {d} holds no public key (*.key files); copy each "
                            f"subscriber's NAME.key there")
    if len(files) > MAX_AUTHORIZED_KEYS:
        raise CurveKeyError(f"{option}: {d} holds {len(files)} keys, must be <= "
                            f"{MAX_AUTHORIZED_KEYS}")
    return [_load_key(f, option, secret=False)[0] for f in files]


@dataclass(frozen=True)
class CurveServer:
    """The publisher's side: its key pair and the public keys allowed to subscribe.

    Attributes
    ----------
    public_key, secret_key : bytes
        The publisher's keys (Z85, 40 characters).
    authorized_dir : Path
        Directory whose ``*.key`` files are the subscribers allowed in (read when the
        publisher starts; restart it to add a subscriber).
    authorized : tuple of bytes
        Those public keys.
    """

    public_key: bytes
    secret_key: bytes
    authorized_dir: Path
    authorized: tuple[bytes, ...]

    @classmethod
    def from_files(cls, secret_key_file: str | os.PathLike[str],
                   authorized_dir: str | os.PathLike[str]) -> CurveServer:
        """Load and check the publisher's secret key file and the authorised directory.

        Raises
        ------
        CurveKeyError
            With the option (``--curve-secret-key``, ``--curve-authorized``), the file and
            what is wrong.
        """
        public, secret = _load_key(secret_key_file, "--curve-secret-key", secret=True)
        keys = _authorized_keys(authorized_dir, "--curve-authorized")
        return cls(public, secret, Path(authorized_dir), tuple(keys))

    def start_authenticator(self, context) -> Any:
        """Start the ZAP handler of ``context`` that admits only the authorised keys.

        Returns
        -------
        zmq.auth.thread.ThreadAuthenticator
            Stop it (``.stop()``) before terminating the context.
        """
        from zmq.auth.thread import ThreadAuthenticator

        auth = ThreadAuthenticator(context)
        auth.start()
        # The keys were checked above; hand them over directly rather than letting zmq
        # re-read the directory (which would ignore a file it cannot parse).
        auth.configure_curve_callback(domain="*", credentials_provider=_KeySet(self.authorized))
        return auth

    def apply(self, sock) -> None:
        """Make ``sock`` a CURVE server with these keys (before it binds)."""
        sock.curve_secretkey = self.secret_key
        sock.curve_publickey = self.public_key
        sock.curve_server = True


class _KeySet:
    """Credentials provider of the ZAP handler: is this client's public key authorised?"""

    def __init__(self, keys):
        self._keys = frozenset(bytes(k) for k in keys)

    def callback(self, domain: str, key: bytes) -> bool:
        # the authenticator passes the client's public key Z85-encoded, as the files hold it
        return bytes(key) in self._keys


@dataclass(frozen=True)
class CurveClient:
    """A subscriber's side: its key pair and the publisher's public key.

    Attributes
    ----------
    public_key, secret_key : bytes
        The subscriber's keys (Z85).
    server_key : bytes
        The publisher's public key (Z85): the subscriber talks only to the holder of the
        matching secret key.
    """

    public_key: bytes
    secret_key: bytes
    server_key: bytes

    @classmethod
    def from_files(cls, secret_key_file: str | os.PathLike[str],
                   server_key_file: str | os.PathLike[str]) -> CurveClient:
        """Load the subscriber's secret key file and the publisher's public key file.

        Raises
        ------
        CurveKeyError
            With the option, the file and what is wrong.
        """
        public, secret = _load_key(secret_key_file, "--curve-secret-key", secret=True)
        server, _ = _load_key(server_key_file, "--curve-server-key", secret=False)
        return cls(public, secret, server)

    def apply(self, sock) -> None:
        """Configure a (SUB) socket as a CURVE client; call before ``connect``."""
        sock.curve_secretkey = self.secret_key
        sock.curve_publickey = self.public_key
        sock.curve_serverkey = self.server_key


def generate_keys(directory: str | os.PathLike[str],
                  clients: tuple[str, ...] | list[str] = ("client",),
                  server: str = "server") -> dict[str, Any]:
    """Create a publisher key pair and subscriber key pairs, and authorise the subscribers.

    Writes ``DIR/SERVER.key`` (public, give it to subscribers), ``DIR/SERVER.key_secret``
    (the publisher's ``--curve-secret-key``), for each client ``DIR/NAME.key`` and
    ``DIR/NAME.key_secret`` (the subscriber's ``--curve-secret-key``), and a copy of each
    client's public key in ``DIR/authorized/`` (the publisher's ``--curve-authorized``).
    Secret files are readable by their owner only. Existing files are never replaced.

    Parameters
    ----------
    directory : str or os.PathLike
        Created if missing (mode 0700).
    clients : sequence of str
        Names of the subscriber key pairs.
    server : str
        Name of the publisher key pair.

    Returns
    -------
    dict
        Paths written, JSON-ready.

    Raises
    ------
    CurveKeyError
        If a name is not a plain file name or a key file of that name exists.
    """
    import zmq.auth

    d = Path(directory)
    names = [server, *clients]
    for name in names:
        if not name or "/" in name or name.startswith(".") or name == "authorized":
            raise CurveKeyError(f"key name {name!r}: must be a plain file name")
    if len(set(names)) != len(names):
        raise CurveKeyError(f"key names must differ, got {names}")
    auth_dir = d / "authorized"
    for name in names:
        for f in (d / f"{name}.key", d / f"{name}.key_secret"):
            if f.exists():
                raise CurveKeyError(f"keys generate: {f} exists; choose another DIR or --name")
    for name in clients:
        if (auth_dir / f"{name}.key").exists():
            raise CurveKeyError(f"keys generate: {auth_dir / f'{name}.key'} exists")
    d.mkdir(mode=0o700, parents=True, exist_ok=True)
    auth_dir.mkdir(mode=0o700, exist_ok=True)
    out: dict[str, Any] = {"directory": str(d), "authorized": str(auth_dir), "clients": {}}
    for name in names:
        public, secret = zmq.auth.create_certificates(d, name)
        os.chmod(secret, 0o600)
        entry = {"public": str(public), "secret": str(secret)}
        if name == server:
            out["server"] = entry
        else:
            Path(auth_dir / f"{name}.key").write_bytes(Path(public).read_bytes())
            out["clients"][name] = entry
    return out


# --------------------------------------------------------------------------- argparse
def add_curve_arguments(parser: argparse.ArgumentParser, role: str) -> None:
    """Add the ``--curve-*`` options of a publisher (``role="server"``) or a subscriber
    (``role="client"``) to an argparse parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    role : {"server", "client"}
        ``server``: ``--curve-secret-key FILE`` and ``--curve-authorized DIR``;
        ``client``: ``--curve-secret-key FILE`` and ``--curve-server-key FILE``.
    """
    if role not in ("server", "client"):
        raise ValueError(f"role must be 'server' or 'client', got {role!r}")
    g = parser.add_argument_group("CurveZMQ security (docs/protocol.md, Security)")
    if role == "server":
        g.add_argument("--curve-secret-key", metavar="FILE", default=None,
                       help="the publisher's secret key (SERVER.key_secret from shipradar keys "
                            "generate): encrypt the stream and authenticate subscribers")
        g.add_argument("--curve-authorized", metavar="DIR", default=None,
                       help="directory of the public keys (*.key) allowed to subscribe")
    else:
        g.add_argument("--curve-secret-key", metavar="FILE", default=None,
                       help="this subscriber's secret key (NAME.key_secret)")
        g.add_argument("--curve-server-key", metavar="FILE", default=None,
                       help="the publisher's public key (SERVER.key)")


def curve_from_args(args: argparse.Namespace, role: str) -> CurveServer | CurveClient | None:
    """The CURVE configuration the parsed ``--curve-*`` options ask for (None: none given).

    Raises
    ------
    CurveKeyError
        If only some of the role's options are given, or a key file or directory is unusable.
    """
    secret = getattr(args, "curve_secret_key", None)
    if role == "server":
        other, other_opt, wanted = getattr(args, "curve_authorized", None), \
            "--curve-authorized", "DIR"
    elif role == "client":
        other, other_opt, wanted = getattr(args, "curve_server_key", None), \
            "--curve-server-key", "FILE"
    else:
        raise ValueError(f"role must be 'server' or 'client', got {role!r}")
    if secret is None and other is None:
        return None
    if secret is None:
        raise CurveKeyError(f"{other_opt} needs --curve-secret-key FILE too")
    if other is None:
        raise CurveKeyError(f"--curve-secret-key needs {other_opt} {wanted} too")
    if role == "server":
        return CurveServer.from_files(secret, other)
    return CurveClient.from_files(secret, other)
