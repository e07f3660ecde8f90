// Skeletons, BVH files and the BVH <-> pose conversion.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "motionkit/bvh.hpp"
#include "motionkit/bvh_pose.hpp"
#include "motionkit/skeleton.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace motionkit::python {
namespace {

constexpr std::uintmax_t kMaxFileBytes = std::uintmax_t{4} << 30;  // 4 GiB

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error(path + ": cannot open the file");
  const std::streamoff size = in.tellg();
  if (size < 0) throw Error(path + ": cannot read the file");
  if (static_cast<std::uintmax_t>(size) > kMaxFileBytes) {
    throw Error(path + ": the file is larger than 4 GiB");
  }
  std::string text(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  if (!in.read(text.data(), size)) throw Error(path + ": cannot read the file");
  return text;
}

std::optional<ChannelType> ParseChannel(const std::string& name) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition",
                                "Xrotation", "Yrotation", "Zrotation"};
  for (int i = 0; i < 6; ++i) {
    if (name == names[i]) return static_cast<ChannelType>(i);
  }
  return std::nullopt;
}

// A skeleton from plain arrays, for skeletons that do not come from a file.
Skeleton MakeSkeleton(const std::vector<std::string>& names, const std::vector<int>& parents,
                      const Eigen::Ref<const RowMatrixXd>& offsets,
                      const std::vector<bool>& end_sites,
                      const std::vector<std::vector<std::string>>& channels) {
  const std::size_t n = names.size();
  if (parents.size() != n || end_sites.size() != n || channels.size() != n ||
      static_cast<std::size_t>(offsets.rows()) != n || offsets.cols() != 3) {
    throw Error("Skeleton: names, parents, offsets (n x 3), end_sites and channels must all have " +
                std::to_string(n) + " entries");
  }
  Skeleton skeleton;
  skeleton.joints.resize(n);
  int column = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Joint& joint = skeleton.joints[i];
    joint.name = names[i];
    joint.parent = parents[i];
    joint.offset = offsets.row(static_cast<Eigen::Index>(i)).transpose();
    joint.end_site = end_sites[i];
    if (channels[i].size() > static_cast<std::size_t>(kMaxChannelsPerJoint)) {
      throw Error("Skeleton: joint '" + joint.name + "' has " + std::to_string(channels[i].size()) +
                  " channels; at most 6");
    }
    joint.channel_count = static_cast<int>(channels[i].size());
    joint.first_channel = column;
    for (std::size_t c = 0; c < channels[i].size(); ++c) {
      const auto type = ParseChannel(channels[i][c]);
      if (!type) throw Error("Skeleton: joint '" + joint.name + "' has an unknown channel '" + channels[i][c] + "'");
      joint.channels[c] = *type;
    }
    column += joint.channel_count;
  }
  skeleton.channel_count = column;
  skeleton.Validate().ThrowIfFailed();
  return skeleton;
}

// Files may carry names that are not UTF-8; Blender's names must be.
py::list SkeletonNames(const Skeleton& s) {
  py::list out;
  for (const Joint& j : s.joints) {
    out.append(py::reinterpret_steal<py::str>(
        PyUnicode_DecodeUTF8(j.name.data(), static_cast<py::ssize_t>(j.name.size()), "replace")));
  }
  return out;
}

py::array_t<std::int32_t> SkeletonParents(const Skeleton& s) {
  py::array_t<std::int32_t> out(static_cast<py::ssize_t>(s.joints.size()));
  auto view = out.mutable_unchecked<1>();
  for (std::size_t i = 0; i < s.joints.size(); ++i) view(static_cast<py::ssize_t>(i)) = s.joints[i].parent;
  return out;
}

RowMatrixXd SkeletonOffsets(const Skeleton& s) {
  RowMatrixXd out(static_cast<Eigen::Index>(s.joints.size()), 3);
  for (std::size_t i = 0; i < s.joints.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = s.joints[i].offset.transpose();
  return out;
}

py::array_t<bool> SkeletonEndSites(const Skeleton& s) {
  py::array_t<bool> out(static_cast<py::ssize_t>(s.joints.size()));
  auto view = out.mutable_unchecked<1>();
  for (std::size_t i = 0; i < s.joints.size(); ++i) view(static_cast<py::ssize_t>(i)) = s.joints[i].end_site;
  return out;
}

std::vector<int> SkeletonFirstChannels(const Skeleton& s) {
  std::vector<int> out;
  for (const Joint& j : s.joints) out.push_back(j.first_channel);
  return out;
}

std::vector<std::vector<std::string>> SkeletonChannels(const Skeleton& s) {
  std::vector<std::vector<std::string>> out;
  for (const Joint& j : s.joints) {
    std::vector<std::string> names;
    for (int c = 0; c < j.channel_count; ++c) names.emplace_back(ChannelName(j.channels[static_cast<std::size_t>(c)]));
    out.push_back(std::move(names));
  }
  return out;
}

Motion MakeMotion(Eigen::Ref<const RowMatrixXd> values, double frame_time) {
  Motion motion;
  motion.values = values;
  motion.frame_time = frame_time;
  return motion;
}

// The file is read and parsed without the GIL.
py::tuple ReadBvhFile(const std::string& path) {
  Skeleton skeleton;
  Motion motion;
  {
    py::gil_scoped_release release;
    const std::string text = ReadFile(path);
    ReadBvh(text, path, &skeleton, &motion);
  }
  return py::make_tuple(std::move(skeleton), std::move(motion));
}

py::tuple ParseBvhText(const std::string& text, const std::string& source) {
  Skeleton skeleton;
  Motion motion;
  {
    py::gil_scoped_release release;
    ReadBvh(text, source, &skeleton, &motion);
  }
  return py::make_tuple(std::move(skeleton), std::move(motion));
}

void WriteBvhFile(const std::string& path, const Skeleton& skeleton, const Motion& motion) {
  py::gil_scoped_release release;
  const std::string text = WriteBvh(skeleton, motion);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out || !out.write(text.data(), static_cast<std::streamsize>(text.size()))) {
    throw Error(path + ": cannot write the file");
  }
}

py::tuple BvhToPose(const Skeleton& skeleton, Eigen::Ref<const RowMatrixXd> values,
                    Eigen::Ref<const RowMatrixXd> bone_rest, const QuaternionArg& conversion, double scale) {
  const Eigen::Index frames = values.rows(), joints = static_cast<Eigen::Index>(skeleton.joints.size());
  Output<> rotations(frames, 4 * joints), locations(frames, 3 * joints);
  BvhToPoseJob job(skeleton, values, bone_rest, rotations.view, locations.view);
  job.conversion = ToQuaternion(conversion);
  job.scale = scale;
  RunWithoutGil(job);
  return py::make_tuple(rotations.array, locations.array);
}

DoubleArray PoseToBvh(const Skeleton& skeleton, Eigen::Ref<const RowMatrixXd> rotations,
                      Eigen::Ref<const RowMatrixXd> locations, Eigen::Ref<const RowMatrixXd> bone_rest,
                      const QuaternionArg& conversion, double scale) {
  Output<> values(rotations.rows(), skeleton.channel_count);
  PoseToBvhJob job(skeleton, rotations, locations, bone_rest, values.view);
  job.conversion = ToQuaternion(conversion);
  job.scale = scale;
  RunWithoutGil(job);
  return values.array;
}

void BindSkeleton(py::module_& m) {
  py::class_<Skeleton>(m, "Skeleton", R"pbdoc(
    Joints in depth-first order (parents before children), end sites included.
    Build one from a BVH file (read_bvh) or from arrays (Skeleton(names, ...)).
  )pbdoc")
      .def(py::init(&MakeSkeleton), "names"_a, "parents"_a, "offsets"_a.noconvert(), "end_sites"_a,
           "channels"_a, R"pbdoc(
        Skeleton(names, parents, offsets, end_sites, channels)
        parents: index of each joint's parent (smaller than its own), -1 for roots.
        offsets: float64 (n, 3), from the parent in its frame.
        channels: per joint a list of BVH channel names ("Xposition", ..., "Zrotation").
      )pbdoc")
      .def("__len__", [](const Skeleton& s) { return s.joints.size(); })
      .def_property_readonly("names", &SkeletonNames, "Joint names; bytes that are not UTF-8 read as U+FFFD.")
      .def_property_readonly("parents", &SkeletonParents)
      .def_property_readonly("offsets", &SkeletonOffsets)
      .def_property_readonly("end_sites", &SkeletonEndSites)
      .def_property_readonly("channel_count", [](const Skeleton& s) { return s.channel_count; })
      .def_property_readonly("first_channels", &SkeletonFirstChannels)
      .def_property_readonly("channels", &SkeletonChannels, "Per joint, its channel names in file order.")
      .def("find", &Skeleton::Find, "name"_a, "Index of the named joint, or -1.");
}

void BindMotion(py::module_& m) {
  py::class_<Motion>(m, "Motion", "Frames of BVH channel values (degrees for rotations).")
      .def(py::init(&MakeMotion), "values"_a, "frame_time"_a)
      .def_readonly("frame_time", &Motion::frame_time)
      .def_property_readonly("frames", &Motion::frames)
      .def_property_readonly(
          "values", [](Motion& motion) -> Eigen::Ref<RowMatrixXd> { return motion.values; },
          py::return_value_policy::reference_internal,
          "float64 (frames, channels), a view into the motion (no copy).");
}

}  // namespace

void BindBvh(py::module_& m) {
  BindSkeleton(m);
  BindMotion(m);
  m.def("read_bvh", &ReadBvhFile, "path"_a, R"pbdoc(
        Read a BVH file: (Skeleton, Motion). Malformed files raise MotionKitError
        with "path:line:column: what (saw 'token')".
      )pbdoc");
  m.def("write_bvh", &WriteBvhFile, "path"_a, "skeleton"_a, "motion"_a, "Write a BVH file.");
  m.def("bvh_to_pose", &BvhToPose, "skeleton"_a, "values"_a.noconvert(), "bone_rest"_a.noconvert(), "conversion"_a,
        "scale"_a, R"pbdoc(
        BVH channels to Blender pose channels.
        bone_rest: (joints, 4) rest orientation w x y z of each bone in armature space.
        conversion: w x y z rotation from BVH space to armature space; scale: BVH units to metres.
        Returns (rotations (frames, 4 * joints) pose quaternions, locations (frames, 3 * joints)).
      )pbdoc");
  m.def("pose_to_bvh", &PoseToBvh, "skeleton"_a, "rotations"_a.noconvert(), "locations"_a.noconvert(),
        "bone_rest"_a.noconvert(), "conversion"_a, "scale"_a,
        "The inverse of bvh_to_pose: BVH channel values (frames, channels), continuous Euler angles.");

  py::module_ testing = TestingModule(m);
  testing.def("parse_bvh", &ParseBvhText, "text"_a, "source"_a = "<string>", "Parse BVH text; like read_bvh.");
  testing.def("format_bvh", &WriteBvh, "skeleton"_a, "motion"_a, py::call_guard<py::gil_scoped_release>(),
              "BVH text that read_bvh/parse_bvh gives back exactly.");
}

}  // namespace motionkit::python
