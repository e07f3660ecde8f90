"""One module per capability, each bpy -> numpy -> native -> numpy -> bpy: BVH import and export (bvh),
retargeting, resampling and key reduction, full-body IK (ik, ik_live) and planted feet (contacts)."""
