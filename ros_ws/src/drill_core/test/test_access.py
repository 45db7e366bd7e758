"""Who may act on the rig: password hashes (checked against hashlib's PBKDF2 of the
same salt, an independent computation), the users file and its errors, loopback
addresses, and the rule that a door other machines reach needs a security directory."""
import hashlib
import stat

import pytest

from drill_core import access
from drill_core.schema import ConfigError


def test_a_password_hash_is_pbkdf2_sha256_of_its_salt_and_verifies_only_its_password():
    salt = bytes(range(16))
    encoded = access.hash_password("s3cret", salt=salt, iterations=1000)
    scheme, iterations, salt_hex, digest_hex = encoded.split("$")
    assert (scheme, iterations, salt_hex) == ("pbkdf2_sha256", "1000", salt.hex())
    assert digest_hex == hashlib.pbkdf2_hmac("sha256", b"s3cret", salt, 1000).hex()
    assert access.verify_password("s3cret", encoded)
    assert not access.verify_password("s3cret ", encoded)
    assert access.hash_password("s3cret") != access.hash_password("s3cret")   # a fresh salt
    with pytest.raises(ValueError, match="empty"):
        access.hash_password("")


def test_users_round_trip_through_a_file_only_its_owner_reads(tmp_path):
    users = access.Users()
    users.add("olivia", access.OPERATOR, "olivia-pass")
    users.add("victor", access.VIEWER, "victor-pass")
    path = tmp_path / "users.yaml"
    users.save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    again = access.Users.load(path)
    assert again.role_of("olivia", "olivia-pass") == "operator"
    assert again.role_of("victor", "victor-pass") == "viewer"
    assert again.role_of("olivia", "victor-pass") is None
    assert again.role_of("mallory", "olivia-pass") is None
    assert "olivia-pass" not in path.read_text()
    with pytest.raises(ValueError, match="role 'admin'"):
        users.add("eve", "admin", "x")
    with pytest.raises(ValueError, match="without spaces"):
        users.add("two words", access.VIEWER, "x")


@pytest.mark.parametrize("text, key", [
    ("users: {olivia: {role: root, password: x}}", "users.olivia.role: 'root' is not one of viewer, operator"),
    ("users: {olivia: {role: operator, password: plain}}", "users.olivia.password: expected pbkdf2_sha256"),
    ("users: {olivia: {role: operator}}", "users.olivia: expected the keys role and password"),
    ("admins: {}", "expected one key, users"),
])
def test_a_bad_users_file_names_the_key(tmp_path, text, key):
    path = tmp_path / "users.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=key):
        access.Users.load(path)


@pytest.mark.parametrize("host, loopback", [
    ("127.0.0.1", True), ("127.1.2.3", True), ("::1", True), ("[::1]", True),
    ("localhost", True), ("LOCALHOST", True),
    ("0.0.0.0", False), ("::", False), ("192.168.1.20", False), ("rig-hmi.example", False),
])
def test_loopback_is_this_machine_only(host, loopback):
    assert access.is_loopback(host) is loopback


def test_a_door_other_machines_reach_needs_a_security_directory(tmp_path):
    access.require_security_beyond_loopback("127.0.0.1", None, "the console")
    access.require_security_beyond_loopback("0.0.0.0", tmp_path, "the console")
    with pytest.raises(ConfigError, match=r"the console on '0.0.0.0' is reachable .*\(rig certs"):
        access.require_security_beyond_loopback("0.0.0.0", None, "the console")


def test_a_security_directory_names_what_is_missing_and_checks_its_token(tmp_path):
    sec = access.SecurityDir(tmp_path)
    with pytest.raises(ConfigError, match="console-token missing .*rig certs"):
        sec.console_token()
    sec.console_token_file.write_text("short\n")
    with pytest.raises(ConfigError, match="at least 16"):
        sec.console_token()
    token = access.new_token()
    access.write_private(sec.console_token_file, (token + "\n").encode())
    assert sec.console_token() == token
    assert access.token_matches(token, sec.console_token())
    assert not access.token_matches(token[:-1], sec.console_token())
