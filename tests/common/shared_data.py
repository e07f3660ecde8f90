"""The real motion capture beside the repository (../shared/data/bvh and its more/ folder)."""
import glob
import os


def bvh_files(bvh_dir):
    """Every .bvh file of the folder and of its more/ subfolder, sorted."""
    return sorted(glob.glob(os.path.join(bvh_dir, "*.bvh")) + glob.glob(os.path.join(bvh_dir, "more", "*.bvh")))
