"""``rig certs DIR`` and ``rig user DIR NAME --role ROLE`` (``python -m
drill_gateway.certificates certs|user ...``): a security directory
(drill_core.access.SecurityDir) with the OPC-UA gateway's self-signed application
certificate, one client certificate the gateway trusts, the console's token, and the
users file (docs/security.md).

The certificates follow OPC UA Part 6 (the application URI in subjectAltName, the key
usages a Basic256Sha256 channel needs); asyncua's certificate helpers build them.
"""
from __future__ import annotations

import argparse
import getpass
import shutil
import socket
import sys
from ipaddress import ip_address
from pathlib import Path

from asyncua.crypto import cert_gen
from cryptography import x509
from cryptography.hazmat.primitives.serialization import Encoding
from cryptography.x509.oid import ExtendedKeyUsageOID

from drill_core import access
from drill_core.schema import ConfigError

SERVER_URI = "urn:drill-rig:opcua-gateway"     # the gateway's application URI
CLIENT_URI = "urn:drill-rig:client"            # the client certificate's application URI
VALID_DAYS = 365


def _alt_names(uri: str, hosts: list[str]) -> list[x509.GeneralName]:
    names: list[x509.GeneralName] = [x509.UniformResourceIdentifier(uri)]
    for host in hosts:
        try:
            names.append(x509.IPAddress(ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    return names


def _write_pair(cert_path: Path, key_path: Path, uri: str, hosts: list[str], use) -> None:
    key = cert_gen.generate_private_key()
    cert = cert_gen.generate_self_signed_app_certificate(
        key, uri, {"organizationName": "drill rig"}, _alt_names(uri, hosts), extended=[use], days=VALID_DAYS)
    access.write_private(key_path, cert_gen.dump_private_key_as_pem(key))
    cert_path.write_bytes(cert.public_bytes(Encoding.DER))


def make(directory: Path, hosts: list[str]) -> access.SecurityDir:
    """The certificates, the trusted client and a console token in ``directory`` (made if
    needed); ``hosts``: the names and addresses the gateway is reached by. Existing users
    are kept; certificates and the token are new."""
    sec = access.SecurityDir(Path(directory))
    sec.path.mkdir(parents=True, exist_ok=True)
    sec.trusted_clients.mkdir(exist_ok=True)
    _write_pair(sec.server_certificate, sec.server_private_key, SERVER_URI, hosts,
                ExtendedKeyUsageOID.SERVER_AUTH)
    _write_pair(sec.client_certificate, sec.client_private_key, CLIENT_URI, hosts,
                ExtendedKeyUsageOID.CLIENT_AUTH)
    shutil.copy(sec.client_certificate, sec.trusted_clients / sec.client_certificate.name)
    access.write_private(sec.console_token_file, (access.new_token() + "\n").encode("utf-8"))
    if not sec.users_file.exists():
        access.Users().save(sec.users_file)
    return sec


def add_user(directory: Path, name: str, role: str, password: str) -> Path:
    sec = access.SecurityDir(Path(directory))
    users = access.Users.load(sec.users_file) if sec.users_file.exists() else access.Users()
    users.add(name, role, password)
    users.save(sec.users_file)
    return sec.users_file


def _password(from_stdin: bool) -> str:
    if from_stdin or not sys.stdin.isatty():
        return sys.stdin.readline().rstrip("\n")
    first = getpass.getpass("password: ")
    if first != getpass.getpass("again: "):
        raise ValueError("the two passwords differ")
    return first


def certs_main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="rig certs", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("directory", type=Path, help="the security directory (made if needed)")
    parser.add_argument("--host", action="append", default=[],
                        help="a name or address clients reach the gateway by (repeatable; "
                             "default: this host's name, localhost and 127.0.0.1)")
    args = parser.parse_args(argv)
    hosts = args.host or [socket.gethostname(), "localhost", "127.0.0.1"]
    sec = make(args.directory, hosts)
    print(f"[rig] security directory {sec.path}: server and client certificates for "
          f"{', '.join(hosts)} (valid {VALID_DAYS} days), the client trusted, a console token; "
          f"add users with: rig user {sec.path} NAME --role operator")
    return 0


def user_main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="rig user", description="add or change a user of "
                                     "a security directory (the password from the terminal, "
                                     "or the first line of stdin)")
    parser.add_argument("directory", type=Path)
    parser.add_argument("name")
    parser.add_argument("--role", required=True, choices=access.ROLES)
    parser.add_argument("--password-stdin", action="store_true")
    args = parser.parse_args(argv)
    try:
        path = add_user(args.directory, args.name, args.role, _password(args.password_stdin))
    except (ValueError, ConfigError) as err:
        print(f"[rig] {err}", file=sys.stderr)
        return 2
    print(f"[rig] {args.name} ({args.role}) in {path}")
    return 0


COMMANDS = {"certs": certs_main, "user": user_main}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] not in COMMANDS:
        print(f"usage: python -m drill_gateway.certificates {{{','.join(COMMANDS)}}} ...",
              file=sys.stderr)
        return 2
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    sys.exit(main())
