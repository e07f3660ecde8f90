"""One module per capability, each read (blender/) -> compute (numpy, native) -> write (blender/): BVH
import and export (bvh), retargeting (+ control_rigs, scene_timing), resampling and key reduction, full-body
IK (ik, ik_live: its settings come from the UI as ik_live.LiveSettings), planted feet (contacts) and the
batch (batch, batch_workers, clip_report, cli)."""
