// Collide two shapes at given poses, without a world: the narrow phase that World::step uses, for
// users and tests.
#pragma once

#include <vector>

#include "signorini/contact.hpp"
#include "signorini/shapes.hpp"

namespace signorini {

/// The contact manifold of shape_a at (p_a, q_a) and shape_b at (p_b, q_b): positions (m, world),
/// orientations as quaternions (w, x, y, z), normalised if not unit. Contacts have gap < margin
/// (m, >= 0: pairs closer than the margin give speculative contacts with a positive gap), normals
/// from A to B, body_a = 0, body_b = 1, alpha = impulse = 0, in the order of docs/conventions.md.
/// Throws std::invalid_argument for non-finite poses, a zero quaternion, a negative margin or an
/// unsupported pair.
std::vector<Contact> collide(const Shape& shape_a, const Vec3& p_a, const Quat4& q_a, const Shape& shape_b,
                             const Vec3& p_b, const Quat4& q_b, double margin = 0.0);

}  // namespace signorini
