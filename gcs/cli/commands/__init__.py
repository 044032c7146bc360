"""Sub-commands of `gcs`, one module each, named in `COMMANDS` with the summary `gcs --help` lists.
Each module defines `register(subparsers)`; the parser it adds sets `func`, called with the parsed
arguments and returning the exit code. A module is imported only when its command runs, so its
heavy dependencies (numba, matplotlib, rerun, pymavlink, ...) never slow down the others."""

COMMANDS = {
    "detector": "simulated sensor readings from a real vehicle (a MAVLink camera component)",
    "experiment": "reproduce the paper's Section 6 figures (CSV + PNG)",
    "fly": "upload, fly and watch the whole fleet until it has landed",
    "plan": "plan closed search trajectories for every UAV",
    "replay": "play a run's Rerun recording back in the viewer",
    "signing": "provision (or remove) MAVLink 2 signing keys on vehicles",
    "sim": "simulated MAVLink vehicles for testing without aircraft",
    "upload": "upload and verify every UAV's mission, fence and rally point",
    "watch": "watch (and command) a fleet over the MQTT fleet bus",
}


def command_module(name: str) -> str:
    """The module that registers the command `name`."""
    return f"{__name__}.{name}"
