// The contact record that the narrow phase writes and the solver reads.
#pragma once

#include <cstdint>

#include "signorini/types.hpp"

namespace signorini {

/// Which feature of a shape a contact point comes from, packed in 64 bits so that the same contact
/// is recognised from one step to the next (see docs/conventions.md, "Feature ids"):
/// id = part << 32 | kind << 28 | index, part = compound part, mesh piece or triangle (0 otherwise),
/// kind one of FeatureKind, index the vertex, edge or face number within that part.
using FeatureId = std::uint64_t;

enum class FeatureKind : std::uint32_t { Shape = 0, Vertex = 1, Edge = 2, Face = 3 };

constexpr FeatureId feature_id(FeatureKind kind, std::uint32_t index, std::uint32_t part = 0) {
  return (static_cast<FeatureId>(part) << 32) | (static_cast<FeatureId>(kind) << 28) | (index & 0x0FFFFFFFu);
}
constexpr FeatureKind feature_kind(FeatureId id) { return static_cast<FeatureKind>((id >> 28) & 0xFu); }
constexpr std::uint32_t feature_index(FeatureId id) { return static_cast<std::uint32_t>(id & 0x0FFFFFFFu); }
constexpr std::uint32_t feature_part(FeatureId id) { return static_cast<std::uint32_t>(id >> 32); }

/// One contact point between bodies A and B (see docs/conventions.md).
struct Contact {
  BodyIndex body_a = -1;  ///< body A (a plane or triangle mesh is always A)
  BodyIndex body_b = -1;  ///< body B
  Vec3 point = Vec3::Zero();   ///< y_i, world (m): midpoint of the witness points on A and B
  Vec3 normal = Vec3::Zero();  ///< n_i, world, unit, pointing from A towards B
  double gap = 0.0;            ///< signed distance along n_i (m); negative = overlap
  FeatureId feature_a = 0;     ///< feature of A the point comes from
  FeatureId feature_b = 0;     ///< feature of B the point comes from
  /// the lever arms of the contact's rows, y - p_A and y - p_B when the point was found (m, world);
  /// a kept contact (its pair kept the manifold an earlier detection found: docs/conventions.md,
  /// "Contact recycling") keeps that detection's, while its gap, point and normal follow the bodies
  Vec3 arm_a = Vec3::Zero(), arm_b = Vec3::Zero();
  bool kept = false;
  // written by the solver (docs/conventions.md, step 3 f and "The Signorini certificate")
  double alpha = 0.0;          ///< normal force alpha_i >= 0 (N), as in the notes
  /// the step's whole normal impulse, sum over its substeps of h alpha_i (N s), applied as
  /// -impulse n on A and +impulse n on B: impulse / dt is the mean normal force over the step
  /// (alpha is the last substep's)
  double impulse = 0.0;
  Vec3 friction = Vec3::Zero();///< friction force on B (N, world, tangent); A gets -friction
  Vec3 force = Vec3::Zero();   ///< total contact force on B, alpha n + friction (N, world)
  /// torsional friction torque on B about n_i (N m; B gets spin_torque n_i, A the opposite); 0
  /// unless the contact has a spin row (its pair's only point, spinning friction > 0)
  double spin_torque = 0.0;
  double normal_velocity = 0.0;///< n^T (v_B(y) - v_A(y)) after the solve (m/s)
  Vec3 slip = Vec3::Zero();    ///< tangential relative velocity of B against A at y after the solve (m/s, world)
};

/// A contact of the previous step as the warm start remembers it (docs/conventions.md, step 3 b):
/// matched by (body_a, body_b, feature_a, feature_b).
struct CachedContact {
  BodyIndex body_a = -1, body_b = -1;
  FeatureId feature_a = 0, feature_b = 0;
  double alpha = 0.0;           ///< normal force after the iterate stage (N)
  Vec3 friction = Vec3::Zero(); ///< friction force on B (N, world)
  double spin = 0.0;            ///< torsional friction torque on B about the normal (N m)
  int order = 0;                ///< position in that step's contact order (first wins on equal keys)
};

}  // namespace signorini
