"""Giving vehicles the station's MAVLink 2 signing key (SETUP_SIGNING) or taking it away, and
checking it took: every vehicle must answer a signed request and sign what it sends
(`gcs signing`; docs/autopilots.md). SETUP_SIGNING is sent over a link the operator trusts."""

from __future__ import annotations

import asyncio
import time

from gcs.errors import UserError
from gcs.links import (
    AUTOPILOT_COMPONENT_ID,
    CommandError,
    MavLink,
    SigningKey,
    mavlink,
    open_links,
    setup_signing_message,
)

ZERO_KEY = SigningKey(bytes(32))


async def _heard(link: MavLink, wanted: list[int], wait_s: float) -> list[int]:
    end = time.monotonic() + wait_s
    while time.monotonic() < end:
        if wanted and all(u in link.systems for u in wanted):
            break
        await asyncio.sleep(0.1)
    heard = sorted(link.systems)
    return [u for u in wanted if u in heard] if wanted else heard


async def _answers(link: MavLink, uid: int) -> bool:
    """Whether a REQUEST_MESSAGE(AUTOPILOT_VERSION) sent on `link` is acknowledged: on a signed
    link the answer also had to check against the key to be seen at all."""
    try:
        await link.command(uid, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                           timeout_s=1.0, retries=2)
    except CommandError:
        return False
    return True


async def _answering(connections: list[str], signing: SigningKey | None, uids: list[int]) -> set[int]:
    """The vehicles among `uids` that acknowledge a request sent on links signed with `signing`."""
    async with open_links(connections, signing=signing) as links:
        await asyncio.sleep(0.5)  # hear who is on which link

        async def answers(uid: int) -> bool:
            on = [link for link in links if uid in link.systems] or links
            return any([await _answers(link, uid) for link in on])

        results = await asyncio.gather(*(answers(u) for u in uids))
    return {u for u, ok in zip(uids, results) if ok}


async def provision(connections: list[str], key: SigningKey, uavs: list[int], *, remove: bool,
                    wait_s: float) -> dict[int, str]:
    """Send SETUP_SIGNING to each vehicle and check the result; vehicle id -> outcome text
    ('ok: ...' or the reason it failed)."""
    # to provision, speak unsigned (the vehicle has no key yet); to remove, speak with the key it holds
    async with open_links(connections, signing=key if remove else None) as links:
        found: dict[int, MavLink] = {}
        for link in links:
            for uid in await _heard(link, uavs, wait_s):
                found.setdefault(uid, link)
        if not found:
            refused = sorted({u for link in links for u in link.guard.refused})
            if refused:
                raise UserError(f"system(s) {', '.join(map(str, refused))} heard, but not signed with key "
                                f"{key.fingerprint}: they hold another key, or none")
            raise UserError(f"no vehicle heard on {', '.join(connections)} within {wait_s:g} s")
        for uid, link in found.items():
            for _ in range(3):  # SETUP_SIGNING has no acknowledgement: send it a few times
                link.send(setup_signing_message(uid, ZERO_KEY if remove else key,
                                                target_component=AUTOPILOT_COMPONENT_ID))
                await asyncio.sleep(0.1)
    outcome = {u: f"failed: not heard within {wait_s:g} s" for u in uavs if u not in found}
    uids = sorted(found)
    if remove:
        unsigned = await _answering(connections, None, uids)
        for uid in uids:
            outcome[uid] = "ok: signing removed" if uid in unsigned else "failed: it does not answer unsigned requests"
        return outcome
    signed = await _answering(connections, key, uids)
    unsigned = await _answering(connections, None, [u for u in uids if u in signed])
    for uid in uids:
        if uid not in signed:
            outcome[uid] = "failed: no answer to a signed request (this link may not accept SETUP_SIGNING)"
        elif uid in unsigned:
            outcome[uid] = (f"ok: signs with key {key.fingerprint}; this link still accepts unsigned requests "
                            "(ArduPilot trusts its first port, USB or SITL's SERIAL0, without signing; its other "
                            "links refuse them)")
        else:
            outcome[uid] = f"ok: signs with key {key.fingerprint}, refuses unsigned requests"
    return outcome
