"""The OPC-UA server (asyncua) of the gateway, without ROS: the address space of
drill_gateway.opcua_names, values pushed in from any thread, and writes of the writable
variables handed to the caller's validating functions before anything is stored.

The server runs its own asyncio loop in a thread. ``update(source, values, stamp_ns)``
may be called from any thread (the ROS callbacks): the newest values of each source are
kept and written into the address space by the loop (a burst coalesces; subscribers see
the changes), with the message's stamp as the SourceTimestamp. Until its first value a
variable is BadWaitingForInitialData; a float that is not
finite keeps the last value with the status UncertainLastUsableValue; a live source
(measurements, estimates) silent for STALE_AFTER_S turns its variables
BadNoCommunication until it speaks again (a client reads no value with a Bad status). Floats with a unit are AnalogItemType with
their EngineeringUnits and EURange (OPC UA Part 8). A client's write of a setpoint or of the automation level goes first to
``on_setpoint(variable, value)`` / ``on_level(value)`` (blocking, run in a worker thread
so the server keeps serving), which answer a drill_gateway.opcua_writes.Outcome: a Good
one lets the value in, a Bad one is the write's status and the variable keeps its value.
Either way the outcome and its reason go to ``Rig/LastWriteResult`` and out as an
OPC-UA event (BaseEventType from the Server object, the reason in Message).

Security (docs/security.md): without a security directory the server offers the ``None``
policy to anonymous sessions that may write, and it binds loopback only (another address
is refused). With one (drill_core.access.SecurityDir) it offers ``Basic256Sha256`` Sign and
SignAndEncrypt only, to client certificates in the directory's ``trusted/``; sessions are
anonymous or a user of ``users.yaml``; anonymous sessions and viewers read, operators
write. A write the session's role may not make is refused BadUserAccessDenied before any
handler sees it, and reported to ``on_refused(text)`` to be recorded.
"""
from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Callable
from datetime import datetime, timezone
from functools import partial
from urllib.parse import urlparse

from asyncua import Server, ua
from asyncua.crypto.permission_rules import USER_TYPES, PermissionRuleset, User, UserRole
from asyncua.crypto.security_policies import SecurityPolicyFactory, SecurityPolicyNone
from asyncua.crypto.truststore import TrustStore
from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions
from asyncua.server.address_space import AttributeService

from drill_core import access
from drill_gateway.certificates import SERVER_URI
from drill_gateway.opcua_names import (LAST_WRITE_RESULT, NAMESPACE_URI, ROOT, UNECE_NAMESPACE,
                                       UNITS, VARIABLES, Unit, Variable, by_source)
from drill_gateway.opcua_writes import BAD_TYPE_MISMATCH, BAD_USER_ACCESS_DENIED, Outcome

DEFAULT_ENDPOINT = "opc.tcp://127.0.0.1:4840/drill-rig"   # this machine only (docs/gateways.md)
SERVER_NAME = "Drill rig OPC-UA gateway"
VARIANT = {"float": ua.VariantType.Double, "bool": ua.VariantType.Boolean,
           "text": ua.VariantType.String}
INITIAL = {"float": math.nan, "bool": False, "text": ""}
STALE_AFTER_S = 3.0         # a live source silent this long: its variables BadNoCommunication
LIVE_SOURCES = ("measurement", "estimate")   # the rest are latched: silence is no news
START_TIMEOUT_S = 120.0     # asyncua builds the standard address space: seconds on a busy machine
SECURE_POLICIES = [ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
                   ua.SecurityPolicyType.Basic256Sha256_Sign]
# the client certificate checks of a secured gateway: in trusted/, in its validity, with
# the key usages and the application URI OPC UA asks of a client
CLIENT_CHECKS = CertificateValidatorOptions.TRUSTED_VALIDATION | CertificateValidatorOptions.PEER_CLIENT


def check_endpoint(endpoint: str, security: access.SecurityDir | None = None) -> str:
    """``endpoint`` if it is an ``opc.tcp://host:port/path`` URL that may be served with
    ``security`` (none: loopback only); ValueError otherwise."""
    url = urlparse(endpoint)
    try:
        port = url.port
    except ValueError:
        port = None
    if url.scheme != "opc.tcp" or not url.hostname or port is None:
        raise ValueError(f"OPC-UA endpoint {endpoint!r}: expected opc.tcp://HOST:PORT/PATH, "
                         f"e.g. {DEFAULT_ENDPOINT}")
    access.require_security_beyond_loopback(url.hostname, security, f"OPC-UA endpoint {endpoint}")
    return endpoint


def eu_information(unit: Unit) -> ua.EUInformation:
    """OPC UA Part 8 EngineeringUnits of ``unit`` (UNECE common code)."""
    return ua.EUInformation(NamespaceUri=UNECE_NAMESPACE, UnitId=unit.unit_id,
                            DisplayName=ua.LocalizedText(unit.symbol),
                            Description=ua.LocalizedText(unit.name))


class _GatedAttributeService(AttributeService):
    """asyncua's attribute service with a gate in front of each write: the gate answers a
    StatusCode to refuse it, None to let it through."""

    def __init__(self, aspace, gate):
        super().__init__(aspace)
        self._gate = gate

    async def write(self, params: ua.WriteParameters, user=None) -> list[ua.StatusCode]:
        results = []
        for item in params.NodesToWrite:
            refused = await self._gate(item, user)
            if refused is not None:
                results.append(refused)
                continue
            one = ua.WriteParameters(NodesToWrite=[item])
            results += await (super().write(one, user=user) if user is not None
                              else super().write(one))
        return results


class _ServiceRuleset(PermissionRuleset):
    """Every session may call the services a client reads, subscribes and writes with (the
    gate decides each write by role, so a refused one is recorded); none may change the
    address space."""

    def __init__(self):
        self._allowed = frozenset(ua.NodeId(i) for i in USER_TYPES)

    def check_validity(self, user, action_type_id, body) -> bool:
        return action_type_id in self._allowed


class _NoService(PermissionRuleset):
    """The ruleset of an unsecured channel on a secured gateway: no service at all."""

    def check_validity(self, user, action_type_id, body) -> bool:
        return False


class _UserManager:
    """asyncua's user manager over drill_core.access.Users: an anonymous session reads, a
    user's name and password give its role, a wrong one no session (BadUserAccessDenied)."""

    def __init__(self, users: access.Users):
        self.users = users
        self.roles: dict[str, str] = {}          # session user name -> role

    def get_user(self, iserver, username=None, password=None, certificate=None) -> User | None:
        if username is None:
            return User(role=UserRole.Anonymous)
        role = self.users.role_of(username, password or "")
        if role is None:
            return None
        self.roles[username] = role
        return User(role=UserRole.User, name=username)


class Gateway:
    """The server on ``endpoint``; ``start`` it, feed it with ``update``, ``stop`` it."""

    def __init__(self, endpoint: str = DEFAULT_ENDPOINT,
                 on_setpoint: Callable[[Variable, object], Outcome] | None = None,
                 on_level: Callable[[object], Outcome] | None = None,
                 security: access.SecurityDir | None = None,
                 on_refused: Callable[[str], None] | None = None):
        self.endpoint = check_endpoint(endpoint, security)
        self.security = security
        self._users: _UserManager | None = None
        if security is not None:
            security.require(security.server_certificate, security.server_private_key,
                             security.trusted_clients, security.users_file)
            self._users = _UserManager(access.Users.load(security.users_file))
        self._on_refused = on_refused or (lambda text: None)
        self._on_setpoint = on_setpoint or (lambda v, value: Outcome("BadNotWritable", "read only"))
        self._on_level = on_level or (lambda value: Outcome("BadNotWritable", "read only"))
        self._lock = threading.Lock()
        self._pending: dict[str, tuple[dict, int | None]] = {}
        self._heard: dict[str, float] = {}     # source -> when its last update came (monotonic)
        self._silent: set[str] = set()         # live sources marked BadNoCommunication
        self._last: dict[ua.NodeId, object] = {}   # the last usable value of each variable
        self.stale_after_s = STALE_AFTER_S
        self._flush_due = False
        self._nodes: dict[tuple[str, str], ua.NodeId] = {}
        self._writable: dict[ua.NodeId, Variable] = {}
        self._ready = threading.Event()
        self._stopped: asyncio.Event | None = None      # set by stop(): the loop ends
        self._error: BaseException | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self.writes = {"accepted": 0, "refused": 0}

    # ------------------------------------------------------------------ life cycle
    def start(self) -> None:
        """Serve; returns once clients can connect, raises what kept the server from it."""
        self._thread = threading.Thread(target=self._run, name="opcua-gateway", daemon=True)
        self._thread.start()
        if not self._ready.wait(START_TIMEOUT_S):
            raise RuntimeError(f"the OPC-UA server on {self.endpoint} did not start within "
                               f"{START_TIMEOUT_S:g} s")
        if self._error is not None:
            raise RuntimeError(f"the OPC-UA server on {self.endpoint} could not start: "
                               f"{self._error}") from self._error

    def stop(self) -> None:
        if self._loop is not None and self._loop.is_running():
            asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop).result(START_TIMEOUT_S)
        if self._thread is not None:
            self._thread.join(START_TIMEOUT_S)

    def _run(self) -> None:
        self._loop = asyncio.new_event_loop()
        try:
            self._stopped = asyncio.Event()
            self._loop.run_until_complete(self._build())
        except BaseException as err:   # reported to start()'s caller
            self._error = err
            self._loop.close()
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_until_complete(self._stopped.wait())
        self._loop.close()

    async def _shutdown(self) -> None:
        self._watch.cancel()
        await self._server.stop()
        self._stopped.set()

    async def _build(self) -> None:
        server = self._server = Server(user_manager=self._users)
        await server.init()
        server.set_endpoint(self.endpoint)
        server.set_server_name(SERVER_NAME)
        if self.security is None:
            server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        else:
            await self._secure(server)
        idx = await server.register_namespace(NAMESPACE_URI)
        rig = await server.nodes.objects.add_object(idx, ROOT)
        folders = {}
        for variable in VARIABLES:
            parent = rig
            if variable.folder:
                if variable.folder not in folders:
                    folders[variable.folder] = await rig.add_folder(idx, variable.folder)
                parent = folders[variable.folder]
            node = await parent.add_variable(idx, variable.name, INITIAL[variable.kind],
                                             varianttype=VARIANT[variable.kind])
            await node.write_attribute(ua.AttributeIds.Description, ua.DataValue(ua.Variant(
                ua.LocalizedText(variable.description), ua.VariantType.LocalizedText)))
            if variable.unit:
                await self._analog_item(node, idx, variable)
            await self._set(node.nodeid, variable.kind, INITIAL[variable.kind],
                            status="BadWaitingForInitialData")
            if variable.writable:
                await node.set_writable()
                self._writable[node.nodeid] = variable
            self._nodes[(variable.source, variable.field)] = node.nodeid
        self._last_result = (await rig.add_variable(idx, LAST_WRITE_RESULT, "",
                                                    varianttype=ua.VariantType.String)).nodeid
        self._events = await server.get_event_generator()
        server.iserver.attribute_service = _GatedAttributeService(server.iserver.aspace, self._gate)
        await server.start()
        self._watch = asyncio.ensure_future(self._watch_silence())

    @staticmethod
    async def _analog_item(node, idx: int, variable: Variable) -> None:
        """Make ``node`` a Part 8 AnalogItemType: its type definition, EURange and
        EngineeringUnits."""
        await node.delete_reference(ua.NodeId(ua.ObjectIds.BaseDataVariableType),
                                    ua.ObjectIds.HasTypeDefinition, bidirectional=False)
        await node.add_reference(ua.NodeId(ua.ObjectIds.AnalogItemType),
                                 ua.ObjectIds.HasTypeDefinition, bidirectional=False)
        low, high = variable.eu_range
        for name, value in (("EURange", ua.Range(Low=low, High=high)),
                            ("EngineeringUnits", eu_information(UNITS[variable.unit]))):
            await node.add_property(ua.NodeId("/".join((*variable.path, name)), idx),
                                    ua.QualifiedName(name, 0), value)

    async def _secure(self, server: Server) -> None:
        sec = self.security
        await server.set_application_uri(SERVER_URI)
        await server.load_certificate(str(sec.server_certificate))
        await server.load_private_key(str(sec.server_private_key))
        server.set_security_policy(SECURE_POLICIES, permission_ruleset=_ServiceRuleset())
        # asyncua keeps an unsecured channel open for discovery (GetEndpoints) although no
        # None endpoint is offered, and would serve a session on it to a client that ignores
        # the endpoints: such a channel gets a ruleset that refuses every service
        server._policies.append(SecurityPolicyFactory(SecurityPolicyNone, ua.MessageSecurityMode.None_,
                                                      permission_ruleset=_NoService()))
        server.set_identity_tokens([ua.AnonymousIdentityToken, ua.UserNameIdentityToken])
        trusted = TrustStore([sec.trusted_clients], [])
        await trusted.load()
        server.set_certificate_validator(CertificateValidator(CLIENT_CHECKS, trusted))

    def role(self, user: User | None) -> str:
        """The role of a session's ``user``: anyone on an open (loopback) gateway writes."""
        if self._users is None:
            return access.OPERATOR
        if user is None or user.role is not UserRole.User:
            return access.ANONYMOUS
        return self._users.roles.get(user.name, access.ANONYMOUS)

    # ------------------------------------------------------------------ values in
    def update(self, source: str, values: dict, stamp_ns: int | None = None) -> None:
        """The newest ``values`` (message field -> SI value) of ``source``, stamped
        ``stamp_ns`` (ns since the epoch; None: the server's time); any thread."""
        by_source(source)            # an unknown source is an error here, not in the loop
        with self._lock:
            self._pending[source] = (values, stamp_ns)
            self._heard[source] = time.monotonic()
            loop = self._loop
            if self._flush_due or loop is None or not self._ready.is_set() or loop.is_closed():
                return
            self._flush_due = True
        try:
            loop.call_soon_threadsafe(lambda: loop.create_task(self._flush()))
        except RuntimeError:       # the loop closed in between: the server has stopped
            pass

    async def _flush(self) -> None:
        with self._lock:
            pending, self._pending, self._flush_due = self._pending, {}, False
            self._silent -= set(pending)
        for source, (values, stamp_ns) in pending.items():
            when = None if stamp_ns is None else \
                datetime.fromtimestamp(stamp_ns / 1e9, tz=timezone.utc)
            for variable in by_source(source):
                if variable.field in values:
                    await self._set(self._nodes[(source, variable.field)], variable.kind,
                                    values[variable.field], when)

    async def _set(self, nodeid: ua.NodeId, kind: str, value, when: datetime | None = None,
                   status: str = "Good") -> None:
        value = {"float": float, "bool": bool, "text": str}[kind](value)
        if status == "Good" and kind == "float" and not math.isfinite(value):
            value, status = self._last.get(nodeid, math.nan), "UncertainLastUsableValue"
        if status == "Good":
            self._last[nodeid] = value
        await self._server.write_attribute_value(nodeid, ua.DataValue(
            Value=ua.Variant(value, VARIANT[kind]),
            StatusCode=ua.StatusCode(getattr(ua.StatusCodes, status)), SourceTimestamp=when))

    async def _watch_silence(self) -> None:
        """Every second: a live source silent for STALE_AFTER_S turns its variables
        BadNoCommunication (their last values kept) until it speaks again."""
        while True:
            await asyncio.sleep(1.0)
            now = time.monotonic()
            with self._lock:
                silent = {s for s in LIVE_SOURCES if s not in self._silent
                          and now - self._heard.get(s, now) > self.stale_after_s}
                self._silent |= silent
            for source in silent:
                for variable in by_source(source):
                    nodeid = self._nodes[(source, variable.field)]
                    await self._set(nodeid, variable.kind, self._last.get(nodeid, math.nan),
                                    status="BadNoCommunication")

    # ------------------------------------------------------------------ writes from clients
    async def _gate(self, item: ua.WriteValue, user: User | None) -> ua.StatusCode | None:
        variable = self._writable.get(item.NodeId)
        if variable is None or item.AttributeId != ua.AttributeIds.Value:
            return None
        variant = item.Value.Value if item.Value is not None else None
        value = variant.Value if variant is not None else None
        role = self.role(user)
        handled = False
        if not access.may_write(role):
            who = f"user {user.name}" if user is not None and user.name else "an anonymous session"
            outcome = Outcome(BAD_USER_ACCESS_DENIED,
                              f"{who} ({role}) may not write: operators write")
        elif variant is None or variant.VariantType != VARIANT[variable.kind]:
            got = variant.VariantType.name if variant is not None else "nothing"
            outcome = Outcome(BAD_TYPE_MISMATCH,
                              f"expected {VARIANT[variable.kind].name}, got {got}")
        else:
            handler = self._on_level if variable.source == "level" \
                else partial(self._on_setpoint, variable)
            outcome = await asyncio.get_running_loop().run_in_executor(None, handler, value)
            handled = True
        text = outcome.describe(f"{'/'.join(variable.path)} = {value!r}")
        self.writes["accepted" if outcome.good else "refused"] += 1
        await self._set(self._last_result, "text", text)
        await self._events.trigger(message=text)
        if not handled:          # a handler's request records its own outcome (OperatorLink)
            await asyncio.get_running_loop().run_in_executor(None, self._on_refused, text)
        return None if outcome.good else ua.StatusCode(getattr(ua.StatusCodes, outcome.status))
