"""The service's settings, checked before it starts."""

from __future__ import annotations

import ipaddress
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

from core.limits import MAX_SECONDS

#: Environment variable holding the token when ``--token`` is not given.
TOKEN_ENV = "SGT_SERVE_TOKEN"
LOOPBACK_NAMES = ("localhost",)
_HOST = re.compile(r"(?:\[([0-9a-f:.]+)\]|([a-z0-9_](?:[a-z0-9_.-]*[a-z0-9_])?))(?::([0-9]{1,5}))?")


class ConfigError(ValueError):
    """Settings the service refuses to start with (the message says how to fix them)."""


@dataclass(frozen=True)
class ServeConfig:
    host: str = "127.0.0.1"
    port: int = 8765
    token: str | None = None
    allow: tuple[Path, ...] = ()  # folders that @audio / @library paths may name
    workers: int = 2  # generation threads
    queue: int = 8  # requests waiting beyond the running ones; more get 503
    max_body: int = 2_000_000  # bytes of a request body (an upload included); more get 413
    max_text: int = 20_000  # characters of a script or text
    timeout: float = 30.0  # seconds a request may take (reading the body, waiting and working); then 408
    header_timeout: float = 10.0  # seconds a client may take to send a request's headers (sgt_tui.serve.listen)
    weights: str | None = None  # generator weights; None = the shipped ones
    database: str | None = None  # the matching engine's database; None = the shipped one
    stream_idle: float = 60.0  # seconds a stream may wait for its next message
    allow_hosts: tuple[str, ...] = ()  # more names (NAME or NAME:PORT) the Host and Origin checks take (sgt_tui.serve.origin)
    max_streams: int = 32  # WebSocket streams open at once; more are refused (503)
    max_client_streams: int = 8  # of which from one client address
    max_seconds: float = 600.0  # the longest performance a request may make (core/limits.py); longer: 422

    @property
    def base_dir(self) -> Path | None:
        """Where relative @audio / @library paths resolve: the first allowed folder."""
        return self.allow[0] if self.allow else None


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def split_host(value: str) -> tuple[str, int | None] | None:
    """A Host header's (or an origin's) ``NAME``, ``NAME:PORT``, ``[IPV6]`` or ``[IPV6]:PORT`` as
    (the name in lower case, without brackets; the port or None); None when it is not one."""
    m = _HOST.fullmatch(value.strip().lower())
    if m is None:
        return None
    v6, name, port = m.groups()
    if v6 is not None:
        try:
            name = str(ipaddress.IPv6Address(v6))
        except ValueError:
            return None
    if port is not None and not 0 < int(port) <= 65535:
        return None
    return name, None if port is None else int(port)


def checked(config: ServeConfig) -> ServeConfig:
    """``config`` with the token from the environment and the allowed folders resolved; raises
    :class:`ConfigError` for settings that would be unsafe or cannot work."""
    token = config.token if config.token is not None else os.environ.get(TOKEN_ENV) or None
    if token is not None and len(token) < 16:
        raise ConfigError("the token must be at least 16 characters (e.g. python -c 'import secrets; print(secrets.token_urlsafe())')")
    if not is_loopback(config.host) and token is None:
        raise ConfigError(f"--host {config.host} exposes the service beyond this machine: give a token with --token "
                          f"or the {TOKEN_ENV} environment variable (clients send 'Authorization: Bearer TOKEN')")
    for name in config.allow_hosts:
        if split_host(name) is None:
            raise ConfigError(f"--allow-host {name}: not a host name (give NAME or NAME:PORT, e.g. sgt.example.com)")
    allow = []
    for folder in config.allow:
        path = Path(folder).expanduser()
        if not path.is_dir():
            raise ConfigError(f"--allow {folder}: not a folder")
        allow.append(path.resolve())
    for name, value, low in (("--workers", config.workers, 1), ("--queue", config.queue, 0), ("--max-body", config.max_body, 1024),
                             ("--max-text", config.max_text, 1), ("--port", config.port, 0),
                             ("--max-streams", config.max_streams, 1), ("--max-client-streams", config.max_client_streams, 1)):
        if value < low:
            raise ConfigError(f"{name} must be at least {low}")
    if config.port > 65535:
        raise ConfigError("--port must be at most 65535")
    if not config.timeout > 0:
        raise ConfigError("--timeout must be more than 0 seconds")
    if not config.header_timeout > 0:
        raise ConfigError("--header-timeout must be more than 0 seconds")
    if not 0 < config.max_seconds <= MAX_SECONDS:
        raise ConfigError(f"--max-seconds must be more than 0 and at most {MAX_SECONDS:g} (the limit of every sgt command)")
    return replace(config, token=token, allow=tuple(allow), allow_hosts=tuple(name.strip().lower() for name in config.allow_hosts))
