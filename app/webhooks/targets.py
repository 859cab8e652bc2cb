"""Which URLs the service calls: http(s) only, no credentials, and (unless private targets
are allowed) only hosts that resolve to public addresses; the request then goes to the
checked address (``pinned``), so a second DNS answer cannot swap it after the check."""

from __future__ import annotations

import ipaddress
import socket
from typing import Any
from urllib.parse import urlsplit

__all__ = ["TargetRefused", "check_target", "pinned"]


class TargetRefused(ValueError):
    """A webhook URL the service will not call."""


def check_target(url: str, *, allow_private: bool) -> str | None:
    """Refuse URLs the service must not call: not http(s), no host, credentials, or (unless
    ``allow_private``) a host that resolves to a non-public address.

    Returns the checked address to connect to (None with ``allow_private``), so that the
    request cannot be sent to another address by a second, different DNS answer.
    """
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https"):
        raise TargetRefused("the URL must be http:// or https://")
    if not parts.hostname:
        raise TargetRefused("the URL has no host")
    if parts.username or parts.password:
        raise TargetRefused("the URL must not carry credentials")
    if allow_private:
        return None
    try:
        port = parts.port or (443 if parts.scheme == "https" else 80)
        infos = socket.getaddrinfo(parts.hostname, port, proto=socket.IPPROTO_TCP)
    except (OSError, ValueError) as error:
        raise TargetRefused(f"the host {parts.hostname!r} cannot be resolved: {error}") from None
    addresses = [ipaddress.ip_address(info[4][0]) for info in infos]
    for address in addresses:
        if not _is_public(address):
            raise TargetRefused(
                f"the host {parts.hostname!r} resolves to the non-public address {address}; "
                "set SHAPESEARCH_WEBHOOK_ALLOW_PRIVATE=true to allow private targets"
            )
    if not addresses:
        raise TargetRefused(f"the host {parts.hostname!r} has no address")
    return str(addresses[0])


def pinned(url: str, address: str | None) -> tuple[str, dict[str, str], dict[str, Any]]:
    """The URL aimed at ``address`` with the Host header and TLS server name of the original
    host (certificates are still verified against that name). None: the URL unchanged."""
    if address is None:
        return url, {}, {}
    parts = urlsplit(url)
    host = parts.hostname or ""
    literal = f"[{address}]" if ":" in address else address
    netloc = literal if parts.port is None else f"{literal}:{parts.port}"
    host_header = host if parts.port is None else f"{host}:{parts.port}"
    extensions = {"sni_hostname": host} if parts.scheme == "https" else {}
    return parts._replace(netloc=netloc).geturl(), {"host": host_header}, extensions


# IPv6 prefixes that carry an IPv4 address a router may deliver to: NAT64 (RFC 6052, and the
# local-use 64:ff9b:1::/48 of RFC 8215), in their last 32 bits.
_NAT64 = (ipaddress.ip_network("64:ff9b::/96"), ipaddress.ip_network("64:ff9b:1::/48"))


def embedded_ipv4(address: ipaddress.IPv4Address | ipaddress.IPv6Address) -> list[
    ipaddress.IPv4Address
]:
    """The IPv4 addresses an IPv6 address carries and may be routed to: IPv4-mapped and
    -compatible, NAT64, 6to4 (2002::/16) and Teredo (2001::/32: server and client)."""
    if isinstance(address, ipaddress.IPv4Address):
        return []
    found = []
    if address.ipv4_mapped is not None:
        found.append(address.ipv4_mapped)
    if address.sixtofour is not None:
        found.append(address.sixtofour)
    if address.teredo is not None:
        found.extend(address.teredo)
    packed = int(address)
    if any(address in network for network in _NAT64) or packed >> 32 == 0 and packed > 1:
        found.append(ipaddress.IPv4Address(packed & 0xFFFFFFFF))  # NAT64, IPv4-compatible
    return found


def _is_public(address: ipaddress.IPv4Address | ipaddress.IPv6Address) -> bool:
    """Global, and so is every IPv4 address it embeds (a NAT64 or 6to4 form of 127.0.0.1
    is as local as 127.0.0.1)."""
    return address.is_global and all(inner.is_global for inner in embedded_ipv4(address))

