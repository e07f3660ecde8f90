"""The retarget's body stage on the rigs and the clip as read (core.body_clearance): where the target deforms
a mesh, its forearms and hands kept out of its own body, as far as the source keeps its own from its body
where the source has a mesh too (scaled), and its hands onto its body where the source's touch its own
(body_touches). rigs, clip, fit: features/retargeting's."""
from __future__ import annotations

import numpy as np

from ..core import body, body_clearance, rotation_channels
from ..core.retarget_options import RetargetOptions


def keep_out(rigs, clip, fit, rotations, locations, o: RetargetOptions, written) -> body_clearance.Report:
    """Changes the arms' rotation channels in rotations (frames, 4B) in place where they go into the body;
    written: the target bones written (indices; None: all): an arm is kept out only where all of its upper
    arm, forearm and hand are."""
    mesh = rigs.target_read.mesh
    if o.body == "off":
        return body_clearance.Report("off")
    if mesh is None or not body.skins_body(rigs.tgt, mesh):
        return body_clearance.Report("no mesh", mesh.source if mesh is not None else "")
    target_body = body.Body.cached(rigs.tgt, mesh)
    sides = [a.side for a in body_clearance.arms(target_body)
             if written is None or {a.upper_arm, a.forearm, a.hand} <= written]
    clearance = touches = places = None
    if clip.mesh is not None and body.skins_body(rigs.src, clip.mesh):
        source_body = body.Body.cached(rigs.src, clip.mesh)
        clearance = {side: fit.scale * kept for side, kept in
                     body_clearance.clearances(source_body, clip.rotations, clip.heads).items()}
        if o.body_touches:
            touches = body_clearance.touching(source_body, clip.rotations, clip.heads)
            found = body_clearance.touch_places(source_body, clip.rotations, clip.heads, touches)
            places = {side: _on_target(place, rigs.pairs_idx, fit) for side, place in found.items()}
    cleared = body_clearance.clear(target_body, rotations, locations, clip.fps, clearance, o.body_strength, sides,
                                   touches, places)
    return body_clearance.Report("on", mesh.source, {side: int(n.sum()) for side, n in cleared.went_in.items()})


def _on_target(place: body_clearance.Place, pairs_idx, fit) -> body_clearance.Place:
    """The source's touch place on the target: the target bone its bone is paired with, the offsets from its
    head and from the hand's (and the hand's length) turned from the source's armature space into the
    target's and scaled as the root's path is (the target's skin and hand found near them then,
    core.body_clearance); none where the source's bone is not paired."""
    paired = dict(pairs_idx)
    bone = np.array([paired.get(int(b), -1) if b >= 0 else -1 for b in place.bone])
    moved = [np.where((bone >= 0)[:, None], fit.scale * rotation_channels.rotate(fit.space, np.nan_to_num(v)), np.nan)
             for v in (place.offset, place.hand)]
    return body_clearance.Place(bone, *moved, fit.scale * place.reach)
