"""The chains the reference pose decides one by one, and the two ways each may stand: the names a bone
map file, the panel and RetargetOptions.chain_modes share (core/reference_pose decides them). No bpy."""
from __future__ import annotations

CHAINS = ("trunk", "arm.L", "arm.R", "leg.L", "leg.R", "fingers.L", "fingers.R")
MODES = ("KEEP", "MATCH")


def check_modes(modes) -> dict:
    """The user's chain modes ({chain: "KEEP" | "MATCH"}), checked; None for none."""
    modes = dict(modes or {})
    for chain, mode in modes.items():
        if chain not in CHAINS:
            raise ValueError(f"chain_modes: unknown chain {chain!r}; expected one of {', '.join(CHAINS)}")
        if mode not in MODES:
            raise ValueError(f"chain_modes[{chain!r}]: unknown mode {mode!r}; expected KEEP or MATCH")
    return modes
