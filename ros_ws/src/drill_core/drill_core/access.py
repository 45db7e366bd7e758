"""Who may act on the rig through its network doors (docs/security.md): the security
directory's layout, the users file with hashed passwords and roles, the console's access
token, and whether an address is this machine only. Plain Python: the OPC-UA gateway and
the console read the same files through this module.

A security directory (``rig certs DIR`` makes one) holds:

  server-cert.der, server-key.pem   the OPC-UA gateway's application certificate and key
  trusted/                          client application certificates the gateway accepts
  client-cert.der, client-key.pem   a client certificate made with the server's (trusted)
  users.yaml                        users: name -> {role, password (PBKDF2-SHA256 hash)}
  console-token                     the console's write token (one line)

Roles: ``viewer`` reads; ``operator`` reads and writes setpoints, the automation level and
the emergency stop. An anonymous session reads only.
"""
from __future__ import annotations

import hashlib
import hmac
import ipaddress
import os
import secrets
from dataclasses import dataclass
from pathlib import Path

import yaml

from drill_core.schema import ConfigError

VIEWER, OPERATOR, ANONYMOUS = "viewer", "operator", "anonymous"
ROLES = (VIEWER, OPERATOR)               # what a users file may give
WRITE_ROLES = frozenset({OPERATOR})
HASH_SCHEME = "pbkdf2_sha256"
HASH_ITERATIONS = 200_000                # about 0.1 s per login on this project's machines
SALT_BYTES = 16
TOKEN_BYTES = 32
LOOPBACK_NAMES = frozenset({"localhost", "localhost.localdomain", "ip6-localhost"})


def may_write(role: str) -> bool:
    return role in WRITE_ROLES


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address) reaches this machine only: a loopback
    address or the name ``localhost``. ``0.0.0.0`` (every interface) is not."""
    name = host.strip().strip("[]").lower()
    if name in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def require_security_beyond_loopback(host: str, security, what: str) -> None:
    """ConfigError if ``what`` on ``host`` is reachable from other machines and has no
    ``security`` (a security directory): the rule both network doors follow."""
    if security is None and not is_loopback(host):
        raise ConfigError(f"{what} on {host!r} is reachable from other machines: it needs a "
                          "security directory (rig certs DIR, rig user DIR NAME --role "
                          "operator, then --security DIR; docs/security.md)")


# ---------------------------------------------------------------------------- passwords
def hash_password(password: str, salt: bytes | None = None,
                  iterations: int = HASH_ITERATIONS) -> str:
    """``pbkdf2_sha256$ITERATIONS$SALT$HASH`` (hex) of ``password``: what a users file keeps."""
    if not password:
        raise ValueError("a password may not be empty")
    salt = secrets.token_bytes(SALT_BYTES) if salt is None else salt
    digest = hashlib.pbkdf2_hmac("sha256", password.encode("utf-8"), salt, iterations)
    return f"{HASH_SCHEME}${iterations}${salt.hex()}${digest.hex()}"


def _parsed_hash(encoded: str) -> tuple[int, bytes, bytes]:
    """(iterations, salt, digest) of a hash_password string; ValueError if it is not one."""
    parts = encoded.split("$")
    iterations, salt, digest = (int(parts[1]), bytes.fromhex(parts[2]), bytes.fromhex(parts[3])) \
        if len(parts) == 4 and parts[0] == HASH_SCHEME else (0, b"", b"")
    if iterations < 1 or not salt or not digest:
        raise ValueError(f"expected {HASH_SCHEME}$ITERATIONS$SALT$HASH (rig user writes it)")
    return iterations, salt, digest


def verify_password(password: str, encoded: str) -> bool:
    iterations, salt, digest = _parsed_hash(encoded)
    given = hashlib.pbkdf2_hmac("sha256", password.encode("utf-8"), salt, iterations)
    return hmac.compare_digest(given, digest)


# ---------------------------------------------------------------------------- users
@dataclass(frozen=True)
class User:
    name: str
    role: str               # one of ROLES
    password_hash: str      # hash_password's string


class Users:
    """The users file: ``users: {NAME: {role: viewer|operator, password: HASH}}``."""

    def __init__(self, users: dict[str, User] | None = None):
        self.users = dict(users or {})

    @classmethod
    def load(cls, path: Path) -> "Users":
        """The file at ``path``; ConfigError naming the file and the key when it is wrong."""
        try:
            data = yaml.safe_load(Path(path).read_text()) or {}
        except (OSError, yaml.YAMLError) as err:
            raise ConfigError(f"{path}: {err}") from err
        if not isinstance(data, dict) or not isinstance(data.get("users", {}), dict) \
                or set(data) - {"users"}:
            raise ConfigError(f"{path}: expected one key, users: {{NAME: {{role, password}}}}")
        users = {}
        for name, entry in (data.get("users") or {}).items():
            where = f"{path}: users.{name}"
            if not isinstance(entry, dict) or set(entry) != {"role", "password"}:
                raise ConfigError(f"{where}: expected the keys role and password")
            if entry["role"] not in ROLES:
                raise ConfigError(f"{where}.role: {entry['role']!r} is not one of {', '.join(ROLES)}")
            try:
                _parsed_hash(str(entry["password"]))
            except ValueError as err:
                raise ConfigError(f"{where}.password: {err}") from None
            users[str(name)] = User(str(name), entry["role"], str(entry["password"]))
        return cls(users)

    def save(self, path: Path) -> None:
        """Write the file, readable by its owner only (it holds password hashes)."""
        data = {"users": {u.name: {"role": u.role, "password": u.password_hash}
                          for u in self.users.values()}}
        write_private(Path(path), yaml.safe_dump(data, sort_keys=True).encode("utf-8"))

    def add(self, name: str, role: str, password: str) -> None:
        """Add ``name`` or replace its role and password."""
        if not name or any(c.isspace() for c in name):
            raise ValueError(f"user name {name!r}: expected a word without spaces")
        if role not in ROLES:
            raise ValueError(f"role {role!r}: expected one of {', '.join(ROLES)}")
        self.users[name] = User(name, role, hash_password(password))

    def role_of(self, name: str, password: str) -> str | None:
        """The role of ``name`` if ``password`` is its password, else None."""
        user = self.users.get(name)
        if user is None:
            hash_password(password or "-")       # the same time for an unknown name
            return None
        return user.role if verify_password(password, user.password_hash) else None


# ---------------------------------------------------------------------------- the directory
@dataclass(frozen=True)
class SecurityDir:
    """The files of a security directory (the module docstring)."""
    path: Path

    @property
    def server_certificate(self) -> Path:
        return self.path / "server-cert.der"

    @property
    def server_private_key(self) -> Path:
        return self.path / "server-key.pem"

    @property
    def client_certificate(self) -> Path:
        return self.path / "client-cert.der"

    @property
    def client_private_key(self) -> Path:
        return self.path / "client-key.pem"

    @property
    def trusted_clients(self) -> Path:
        return self.path / "trusted"

    @property
    def users_file(self) -> Path:
        return self.path / "users.yaml"

    @property
    def console_token_file(self) -> Path:
        return self.path / "console-token"

    def require(self, *paths: Path) -> None:
        """ConfigError naming what of ``paths`` is missing (and how to make it)."""
        missing = [p.name for p in paths if not p.exists()]
        if missing:
            raise ConfigError(f"security directory {self.path}: {', '.join(missing)} missing "
                              f"(rig certs {self.path} makes them; rig user adds users)")

    def console_token(self) -> str:
        self.require(self.console_token_file)
        token = self.console_token_file.read_text().strip()
        if len(token) < 16:
            raise ConfigError(f"{self.console_token_file}: a token of at least 16 characters expected")
        return token


def new_token() -> str:
    return secrets.token_urlsafe(TOKEN_BYTES)


def token_matches(given: str, expected: str) -> bool:
    return hmac.compare_digest(given.encode("utf-8"), expected.encode("utf-8"))


def write_private(path: Path, data: bytes) -> None:
    """``data`` to ``path``, readable by its owner only (keys, tokens)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as f:
        f.write(data)
    os.chmod(path, 0o600)            # also when the file was there before
