"""The files a batch takes from the files and folders a user names."""
import pytest

from core import batch_inputs


def _tree(tmp_path):
    for name in ("a/walk.bvh", "a/run.FBX", "a/notes.txt", "a/deep/jump.glb", "b/idle.gltf", "b/idle.bin"):
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("x")
    return tmp_path


def test_folders_are_searched_recursively_for_motion_files_in_a_stable_order(tmp_path):
    root = _tree(tmp_path)
    found = batch_inputs.collect([root / "a", root / "b"])
    assert [p[len(str(root)) + 1:] for p in found] == ["a/run.FBX", "a/walk.bvh", "a/deep/jump.glb", "b/idle.gltf"]
    assert batch_inputs.collect([root / "a"], recursive=False) == [str(root / "a/run.FBX"), str(root / "a/walk.bvh")]


def test_a_glob_filters_folders_and_a_file_named_is_taken_once_whatever_it_is(tmp_path):
    root = _tree(tmp_path)
    assert batch_inputs.collect([root], pattern="*.bvh") == [str(root / "a/walk.bvh")]
    named = batch_inputs.collect([root / "a/notes.txt", root / "a", root / "a/walk.bvh"])
    assert named[0] == str(root / "a/notes.txt") and named.count(str(root / "a/walk.bvh")) == 1


def test_an_input_that_does_not_exist_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere"):
        batch_inputs.collect([tmp_path / "nowhere"])


def test_a_take_is_named_after_its_file_and_the_take_when_there_are_several():
    assert batch_inputs.clip_name("/x/punch.fbx", "mixamo.com", 1) == "punch"
    assert batch_inputs.clip_name("/x/moves.glb", "Run", 3) == "moves|Run"


def test_files_that_share_a_stem_keep_their_extensions_in_their_clips_names():
    stems = batch_inputs.stems(["/a/walk.fbx", "/b/walk.bvh", "/a/run.bvh"])
    assert stems == {"/a/walk.fbx": "walk.fbx", "/b/walk.bvh": "walk.bvh", "/a/run.bvh": "run"}
    assert batch_inputs.clip_name("/a/walk.fbx", "Take 1", 2, stems["/a/walk.fbx"]) == "walk.fbx|Take 1"
