"""The target's F-curves from a retargeted pose (numpy arrays to (channels, values) rows, each bone in its own
rotation mode): what the plan keys, and a plan's bones keyed again once a later stage (the followers, the
props, two hands on a prop) has moved them. rigs: the retarget's _Rigs; plan_: its Plan."""
from __future__ import annotations

import numpy as np

from ..core.rotation_keys import Keyer, bone_path, columns


def target_channels(rigs, rotations, located, locations, only=None, keyed=frozenset(),
                     placeholders=False, keyer=None):
    """The F-curves to key, in each bone's own rotation mode: (channels, values) for the bones the retarget
    moves (and those in keyed) and the root's location, one key per frame; (channels, values) for the bones
    that keep the match pose, one key. only: the bone indices to give (default all). placeholders: the
    keyed bones' values left at zero (the feet's solve fills them in). keyer: core.rotation_keys.Keyer
    of the moving bones in only, in bone order."""
    tgt, target_basis, bone_map_idx = rigs.tgt, rigs.target_basis, rigs.bone_map
    frames = rotations.shape[0]
    scope = [b for b in range(len(tgt)) if only is None or b in only]
    moving = [b for b in scope if bone_map_idx[b] >= 0 or b in located or b in keyed
              or bool(np.any(np.abs(rotations[:, 4 * b:4 * b + 4] @ target_basis[b]) < 1.0 - 1e-12))]
    still = sorted(set(scope) - set(moving))
    later = [b for b in moving if placeholders and b in keyed]  # zeros until the feet's solve
    now = [b for b in moving if b not in later]
    located_bones = [b for b in moving if b in located]
    channels = [(f"{bone_path(tgt.names[b])}.location", k, tgt.names[b]) for b in located_bones for k in range(3)]
    keyers = [(keyer if keyer is not None and not placeholder else Keyer.of(tgt, bones), bones, placeholder)
              for bones, placeholder in ((now, False), (later, True)) if bones]
    # One array for every channel, each keyer writing its own rows: the clip's values are never copied.
    values = np.empty((3 * len(located_bones) + sum(k.rows for k, _, _ in keyers), frames))
    for i, b in enumerate(located_bones):
        values[3 * i:3 * i + 3] = locations[:, 3 * b:3 * b + 3].T
    row = 3 * len(located_bones)
    for keys, bones, placeholder in keyers:
        more, _ = keys(columns(rotations, bones), placeholder=placeholder, out=values[row:row + keys.rows])
        channels += more
        row += keys.rows
    still_channels, still_values = Keyer.of(tgt, still)(columns(rotations[:1], still)) if still else \
        ([], np.empty((0, 1)))
    return (channels, values), (still_channels, still_values)


def rekey(rigs, plan_, bones: set, located=()) -> None:
    """The plan's keys of bones (indices) made again from its pose (plan_.pose), a key on every frame."""
    rotations, locations = plan_.pose
    names = {rigs.tgt.names[b] for b in bones}
    (channels, values), _ = target_channels(rigs, rotations, list(located), locations, only=bones, keyed=bones)
    keep = [i for i, c in enumerate(plan_.still_channels) if c[2] not in names]
    plan_.still_channels = [plan_.still_channels[i] for i in keep]
    plan_.still_values = plan_.still_values[keep]
    rows = [i for i, c in enumerate(plan_.channels) if c[2] not in names]
    where = {(c[0], c[1]): i for i, c in enumerate(plan_.channels)}
    if len(rows) + len(channels) == len(plan_.channels) and all((c[0], c[1]) in where for c in channels):
        # The bones' channels are the plan's already (keyed on every frame): their rows written in place,
        # the clip's other values never copied.
        plan_.values[[where[(c[0], c[1])] for c in channels]] = values
        return
    plan_.channels = [plan_.channels[i] for i in rows] + channels
    plan_.values = np.vstack([plan_.values[rows], values])
