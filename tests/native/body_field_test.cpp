#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "body_boxes.hpp"
#include "motionkit/body_field.hpp"

namespace motionkit {
namespace {

using namespace testing_boxes;

// The box's distance everywhere: exact (doubles) within two cells of a face, where it is measured point to
// triangle; beyond, carried by the neighbours' nearest points. Outside a convex body every cell's nearest
// point is some neighbour's (a box's Voronoi regions are convex), so it stays exact; inside, a cell near the
// medial planes may keep a neighbour's nearest point on the wrong face, at most about a tenth of a cell
// nearer than the right one (the vector transform's known error).
TEST(BodyField, ABoxsSignedDistanceIsExactNearItAndWithinATenthOfACellInside) {
  const Eigen::Vector3d h(0.3, 0.2, 0.5);
  const double spacing = 0.037;
  const Field f = Build(Box(h), std::vector<int>(8, 0), spacing, 0.2);
  double near = 0.0, outside = 0.0, inside = 0.0;
  for (Eigen::Index cell = 0; cell < f.distance.size(); ++cell) {
    const double want = BoxDistance(f.Centre(cell), h);
    const double error = std::abs(f.distance[cell] - want);
    if (std::abs(want) < 2.0 * spacing) {
      near = std::max(near, error);
    } else if (want > 0.0) {
      outside = std::max(outside, error);
    } else {
      inside = std::max(inside, error);
    }
  }
  EXPECT_LT(near, 1e-12);
  EXPECT_LT(outside, 1e-12);
  EXPECT_LT(inside, 0.1 * spacing);
}

// A hole (one triangle gone) flips only the rays that pass through it, along one axis: the other two
// axes' vote keeps every cell's sign.
TEST(BodyField, AHoleInTheMeshDoesNotTurnItsInsideOut) {
  const Eigen::Vector3d h(0.3, 0.2, 0.5);
  Mesh open = Box(h);
  open.triangles.conservativeResize(11, 3);
  const Field f = Build(open, std::vector<int>(8, 0), 0.041, 0.15);
  for (Eigen::Index cell = 0; cell < f.distance.size(); ++cell) {
    const double want = BoxDistance(f.Centre(cell), h);
    if (std::abs(want) > 1e-9) {
      EXPECT_EQ(f.distance[cell] < 0.0, want < 0.0) << "cell " << cell;
    }
  }
}

// A box inside a box, both wound outwards (a coat over a body): inside the inner one is inside too, as it
// would not be by the parity of the crossings (two shells crossed).
TEST(BodyField, InsideTwoShellsIsInside) {
  const Eigen::Vector3d outer(0.4, 0.3, 0.6), inner(0.2, 0.1, 0.3);
  const Mesh a = Box(outer), b = Box(inner);
  Mesh both{RowMatrixXd(16, 3), TriangleMatrix(24, 3)};
  both.vertices << a.vertices, b.vertices;
  both.triangles << a.triangles, b.triangles.array() + 8;
  const Field f = Build(both, std::vector<int>(16, 0), 0.043, 0.15);
  int inside_inner = 0;
  for (Eigen::Index cell = 0; cell < f.distance.size(); ++cell) {
    const Eigen::Vector3d c = f.Centre(cell);
    const double want = BoxDistance(c, outer);
    if (std::abs(want) > 1e-9) {
      EXPECT_EQ(f.distance[cell] < 0.0, want < 0.0) << "cell " << cell;
    }
    inside_inner += BoxDistance(c, inner) < -0.01 ? 1 : 0;
  }
  EXPECT_GT(inside_inner, 20);
}

// Each cell names the bone of the vertex nearest its nearest surface point.
TEST(BodyField, EachCellNamesTheBoneOfTheNearestSurfacesVertex) {
  const Eigen::Vector3d h(0.3, 0.2, 0.5);
  std::vector<int> bones(8);
  for (int v = 0; v < 8; ++v) bones[static_cast<std::size_t>(v)] = (v & 4) ? 7 : 3;  // top 7, bottom 3
  const Field f = Build(Box(h), bones, 0.05, 0.2);
  for (Eigen::Index cell = 0; cell < f.distance.size(); ++cell) {
    const Eigen::Vector3d c = f.Centre(cell);
    // Clear of the middle (where the nearest vertex may be either), the nearer end's bone.
    if (std::abs(c.z()) > 0.15) {
      EXPECT_EQ(f.bone[cell], c.z() > 0 ? 7 : 3) << "cell " << cell;
    }
  }
}

TEST(BodyField, ThreadsChangeNothing) {
  const Mesh m = Box(Eigen::Vector3d(0.3, 0.2, 0.5));
  Eigen::VectorXd d1(8000), d2(8000);
  Eigen::VectorXi b1(8000), b2(8000);
  const Eigen::Vector3d origin(-0.6, -0.6, -0.6);
  BodyFieldJob one(m.vertices, m.triangles, std::vector<int>(8, 0), origin, 0.06, Eigen::Vector3i(20, 20, 20), d1, b1);
  BodyFieldJob two(m.vertices, m.triangles, std::vector<int>(8, 0), origin, 0.06, Eigen::Vector3i(20, 20, 20), d2, b2);
  one.threads = 1;
  two.threads = 2;
  one.Run();
  two.Run();
  EXPECT_TRUE((d1.array() == d2.array()).all() && (b1.array() == b2.array()).all());
  EXPECT_TRUE((d1.array() < 0.0).any());
}

TEST(BodyField, BadInputIsRefusedByName) {
  Mesh m = Box(Eigen::Vector3d(1, 1, 1));
  Eigen::VectorXd distance(8);
  Eigen::VectorXi bone(8);
  m.triangles(4, 1) = 9;
  BodyFieldJob job(m.vertices, m.triangles, std::vector<int>(8, 0), Eigen::Vector3d::Zero(), 1.0,
                   Eigen::Vector3i(2, 2, 2), distance, bone);
  EXPECT_NE(job.Validate().message().find("triangle 4 names vertex 9"), std::string::npos);
  m.triangles(4, 1) = 1;
  m.vertices(5, 2) = std::nan("");
  EXPECT_NE(job.Validate().message().find("vertex 5 is not finite"), std::string::npos);
  m.vertices(5, 2) = 1.0;
  job.vertex_bone.pop_back();
  EXPECT_NE(job.Validate().message().find("one bone per vertex"), std::string::npos);
  job.vertex_bone.push_back(0);
  EXPECT_TRUE(job.Validate().ok());
  job.spacing = 0.0;
  EXPECT_THROW(job.Run(), Error);
}

}  // namespace
}  // namespace motionkit
