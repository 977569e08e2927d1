// Convex polytopes: the box's fixed numbering, and the polytope of a closed convex triangle mesh
// (coplanar neighbouring triangles merged into polygons). Feature ids of contacts are built from
// these numbers, so they are part of the contract (docs/polytope_numbering.md).
//
// Box numbering (half extents (a, b, c)):
//   vertex k = (sx a, sy b, sz c), sx = +1 if k & 1 else -1, sy from k & 2, sz from k & 4:
//     0 (-,-,-)  1 (+,-,-)  2 (-,+,-)  3 (+,+,-)  4 (-,-,+)  5 (+,-,+)  6 (-,+,+)  7 (+,+,+)
//   face 2 i + 0 has normal -e_i, 2 i + 1 has +e_i; loops counter-clockwise seen from outside:
//     face 0 (-x): 0 4 6 2     face 1 (+x): 1 3 7 5
//     face 2 (-y): 0 1 5 4     face 3 (+y): 2 6 7 3
//     face 4 (-z): 0 2 3 1     face 5 (+z): 4 5 7 6
//   edges in order of first appearance (faces 0..5, side k = loop[k] -> loop[k + 1]),
//   as v0 -> v1 (the direction in f0), f0, f1:
//     e0: 0->4 f0 f2    e1: 4->6 f0 f5    e2:  6->2 f0 f3    e3:  2->0 f0 f4
//     e4: 1->3 f1 f4    e5: 3->7 f1 f3    e6:  7->5 f1 f5    e7:  5->1 f1 f2
//     e8: 0->1 f2 f4    e9: 5->4 f2 f5    e10: 6->7 f3 f5    e11: 3->2 f3 f4
//   face_edges (edge of side k of each face):
//     f0: 0 1 2 3   f1: 4 5 6 7   f2: 8 7 9 0   f3: 2 10 5 11   f4: 3 11 4 8   f5: 9 6 10 1
#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "geometry/polytope.hpp"

namespace signorini {
namespace geometry {

Polytope box_polytope(const Vec3& h) {
  Polytope p;
  p.vertices.resize(8, 3);
  for (int k = 0; k < 8; ++k)
    p.vertices.row(k) << ((k & 1) ? h.x() : -h.x()), ((k & 2) ? h.y() : -h.y()), ((k & 4) ? h.z() : -h.z());
  // face s e_i (j = i + 1, k = i + 2 mod 3): s = +1 walks (j, k) signs (-,-), (+,-), (+,+), (-,+);
  // s = -1 walks them the other way round from (-,-): (-,-), (-,+), (+,+), (+,-)
  static const int plus[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  static const int minus[4][2] = {{-1, -1}, {-1, 1}, {1, 1}, {1, -1}};
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    for (int s : {-1, 1}) {
      std::vector<int> loop;
      for (const auto& sign : (s > 0 ? plus : minus)) {
        int signs[3];
        signs[i] = s;
        signs[j] = sign[0];
        signs[k] = sign[1];
        loop.push_back((signs[0] > 0 ? 1 : 0) | (signs[1] > 0 ? 2 : 0) | (signs[2] > 0 ? 4 : 0));
      }
      p.faces.push_back(loop);
      p.normals.push_back(double(s) * Vec3::Unit(i));
      p.offsets.push_back(h[i]);
    }
  }
  build_edges(p, "Box");
  p.centroid = Vec3::Zero();
  return p;
}

void build_edges(Polytope& p, const char* who) {
  std::unordered_map<std::int64_t, int> index;  // undirected edge, keyed min n + max -> edge number
  const std::int64_t n = p.vertices.rows();
  p.edges.clear();
  p.face_edges.assign(p.faces.size(), {});
  for (std::size_t f = 0; f < p.faces.size(); ++f) {
    const std::vector<int>& loop = p.faces[f];
    for (std::size_t k = 0; k < loop.size(); ++k) {
      const int a = loop[k], b = loop[(k + 1) % loop.size()];
      const std::int64_t key = std::min(a, b) * n + std::max(a, b);
      const auto found = index.find(key);
      if (found == index.end()) {
        index.emplace(key, static_cast<int>(p.edges.size()));
        p.face_edges[f].push_back(static_cast<int>(p.edges.size()));
        p.edges.push_back({a, b, static_cast<int>(f), -1});
        continue;
      }
      Polytope::Edge& e = p.edges[found->second];
      if (e.f1 != -1 || e.v0 != b || e.v1 != a)
        throw std::invalid_argument(std::string(who) + ": edge (" + std::to_string(a) + ", " + std::to_string(b) +
                                    ") is used by more than two faces or twice in the same direction");
      e.f1 = static_cast<int>(f);
      p.face_edges[f].push_back(found->second);
    }
  }
  for (const Polytope::Edge& e : p.edges)
    if (e.f1 == -1)
      throw std::invalid_argument(std::string(who) + ": the mesh is open: edge (" + std::to_string(e.v0) + ", " +
                                  std::to_string(e.v1) + ") belongs to a single face");
}

Polytope translated(const Polytope& p, const Vec3& t) {
  Polytope out = p;
  out.vertices.rowwise() += t.transpose();
  for (std::size_t f = 0; f < out.faces.size(); ++f) out.offsets[f] += out.normals[f].dot(t);
  out.centroid += t;
  return out;
}

}  // namespace geometry

namespace {

Polytope from_triangles(const Points& vertices, const Triangles& faces, bool check_convex) {
  const std::string who = "polytope_from_triangles";
  const Eigen::Index n = vertices.rows(), F = faces.rows();
  if (F < 4) throw std::invalid_argument(who + ": a closed polyhedron needs at least 4 triangles, got " + std::to_string(F));
  auto vertex = [&](std::int64_t i) -> Vec3 { return vertices.row(i).transpose(); };

  // the vertices the triangles use, and the size that scales the tolerances
  std::vector<bool> used(static_cast<std::size_t>(n), false);
  for (Eigen::Index t = 0; t < F; ++t)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t i = faces(t, c);
      if (i < 0 || i >= n)
        throw std::invalid_argument(who + ": face " + std::to_string(t) + " has vertex index " + std::to_string(i) +
                                    " outside [0, " + std::to_string(n) + ")");
      if (!vertices.row(i).allFinite())
        throw std::invalid_argument(who + ": vertex " + std::to_string(i) + " is not finite");
      used[static_cast<std::size_t>(i)] = true;
    }
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY), centroid = Vec3::Zero();
  int count = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!used[static_cast<std::size_t>(i)]) continue;
    lo = lo.cwiseMin(vertex(i));
    hi = hi.cwiseMax(vertex(i));
    centroid += vertex(i);
    ++count;
  }
  centroid /= count;
  const double size = (hi - lo).norm();

  // unit normals; (b - a) x (c - a) is twice the area, and degenerate when tiny against size^2
  std::vector<Vec3> area_normal(static_cast<std::size_t>(F)), unit(static_cast<std::size_t>(F));
  for (Eigen::Index t = 0; t < F; ++t) {
    const Vec3 a = vertex(faces(t, 0)), b = vertex(faces(t, 1)), c = vertex(faces(t, 2));
    area_normal[t] = (b - a).cross(c - a);
    if (area_normal[t].norm() <= 1e-12 * size * size)
      throw std::invalid_argument(who + ": face " + std::to_string(t) + " is degenerate (zero area or repeated vertex)");
    unit[t] = area_normal[t].normalized();
  }

  // closed and consistently oriented: every directed edge once, its reverse once
  std::unordered_map<std::int64_t, Eigen::Index> owner;  // directed edge a -> b, keyed a n + b -> triangle
  owner.reserve(static_cast<std::size_t>(3 * F));
  auto key = [n](std::int64_t a, std::int64_t b) { return a * n + b; };
  for (Eigen::Index t = 0; t < F; ++t)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t a = faces(t, c), b = faces(t, (c + 1) % 3);
      if (!owner.emplace(key(a, b), t).second)
        throw std::invalid_argument(who + ": edge (" + std::to_string(a) + ", " + std::to_string(b) +
                                    ") is used twice in the same direction: faces are inconsistently oriented, "
                                    "duplicated or non-manifold");
    }
  for (Eigen::Index t = 0; t < F; ++t)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t a = faces(t, c), b = faces(t, (c + 1) % 3);
      if (!owner.count(key(b, a)))
        throw std::invalid_argument(who + ": the mesh is open: edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") belongs to a single face");
    }

  // convex and outward: every used vertex on or behind every triangle's plane (relative 1e-9);
  // O(triangles x vertices), the one step that is not near-linear
  const double tol = 1e-9 * size;
  for (Eigen::Index t = 0; t < F && check_convex; ++t) {
    const Vec3 a = vertex(faces(t, 0));
    for (Eigen::Index i = 0; i < n; ++i)
      if (used[static_cast<std::size_t>(i)] && unit[t].dot(vertex(i) - a) > tol)
        throw std::invalid_argument(who + ": the mesh is not convex (or not outward): vertex " + std::to_string(i) +
                                    " lies in front of face " + std::to_string(t));
  }

  // merge: a group grows from its first (lowest) triangle over shared edges to triangles whose unit
  // normal is within 1e-9 of the seed's (compared with the seed, so the merge cannot drift)
  std::vector<int> group(static_cast<std::size_t>(F), -1);
  std::vector<std::vector<Eigen::Index>> members;
  for (Eigen::Index seed = 0; seed < F; ++seed) {
    if (group[seed] != -1) continue;
    const int g = static_cast<int>(members.size());
    members.push_back({seed});
    group[seed] = g;
    for (std::size_t q = 0; q < members[g].size(); ++q) {
      const Eigen::Index t = members[g][q];
      for (int c = 0; c < 3; ++c) {
        const Eigen::Index u = owner.at(key(faces(t, (c + 1) % 3), faces(t, c)));
        if (group[u] == -1 && (unit[u] - unit[seed]).norm() <= 1e-9) {
          group[u] = g;
          members[g].push_back(u);
        }
      }
    }
    std::sort(members[g].begin(), members[g].end());
  }

  Polytope p;
  p.vertices = vertices;
  p.centroid = centroid;
  for (std::size_t g = 0; g < members.size(); ++g) {
    // the group's outline: its directed edges whose reverse lies in another group
    std::map<std::int64_t, std::int64_t> next;
    Vec3 normal = Vec3::Zero();
    for (Eigen::Index t : members[g]) {
      normal += area_normal[t];
      for (int c = 0; c < 3; ++c) {
        const std::int64_t a = faces(t, c), b = faces(t, (c + 1) % 3);
        if (group[owner.at(key(b, a))] == static_cast<int>(g)) continue;
        if (!next.emplace(a, b).second)
          throw std::invalid_argument(who + ": the mesh is not convex: the coplanar faces around face " +
                                      std::to_string(members[g].front()) + " do not form one polygon");
      }
    }
    // the loop starts at the first corner of the group's first triangle that lies on it
    std::int64_t start = -1;
    for (int c = 0; c < 3 && start == -1; ++c)
      if (next.count(faces(members[g].front(), c))) start = faces(members[g].front(), c);
    if (start == -1) start = next.begin()->first;  // lowest index on the loop
    std::vector<int> loop;
    std::int64_t v = start;
    do {
      loop.push_back(static_cast<int>(v));
      const auto it = next.find(v);
      if (it == next.end() || loop.size() > next.size()) {
        loop.clear();
        break;
      }
      v = it->second;
    } while (v != start);
    if (loop.size() != next.size())
      throw std::invalid_argument(who + ": the mesh is not convex: the coplanar faces around face " +
                                  std::to_string(members[g].front()) + " do not form one polygon");
    // normal: the area-weighted mean of the group's triangle normals (triangle order);
    // offset: the largest n . v over the loop, so every loop vertex is on or behind the plane
    normal.normalize();
    double offset = -INFINITY;
    for (int i : loop) offset = std::max(offset, normal.dot(vertex(i)));
    p.faces.push_back(std::move(loop));
    p.normals.push_back(normal);
    p.offsets.push_back(offset);
  }
  geometry::build_edges(p, who.c_str());
  return p;
}

}  // namespace

Polytope polytope_from_triangles(const Points& vertices, const Triangles& faces) {
  return from_triangles(vertices, faces, true);
}

Polytope geometry::polytope_from_hull_triangles(const Points& vertices, const Triangles& faces) {
  return from_triangles(vertices, faces, false);
}

}  // namespace signorini
