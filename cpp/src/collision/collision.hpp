// Contact generation: broad phase (FCL dynamic AABB tree), narrow phase (a dispatch table over
// shape pairs: own exact tests for planes, spheres, capsules and polytopes; support functions for
// cylinder pairs; FCL's BVH for candidate triangles of static meshes), manifolds of up to 4 points
// with feature ids, in the contact order of docs/conventions.md. FCL types never appear in this
// header; they stay in fcl_queries.cpp.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "signorini/contact.hpp"
#include "signorini/shapes.hpp"
#include "signorini/model.hpp"
#include "signorini/state.hpp"

namespace signorini::serial { struct Writer; struct Reader; }
namespace signorini::parallel { class Pool; }

namespace signorini::collision {

/// Where a shape is: x_world = R x_body + p.
struct Pose {
  Vec3 p = Vec3::Zero();
  Mat3 R = Mat3::Identity();
};

/// Triangles of a static TriangleMesh whose bounding volumes overlap a box given in the mesh's
/// frame (FCL BVHModel<OBBRSS>); one per TriangleMesh, built once.
class TriangleQuery {
 public:
  explicit TriangleQuery(const TriangleMesh& mesh);
  ~TriangleQuery();
  /// Indices of the triangles whose OBBRSS leaves overlap the axis-aligned box [lo, hi] (mesh
  /// frame, m), in increasing order, written into out (cleared first); stack is the traversal's
  /// scratch. Allocates nothing once out and stack have grown.
  void overlapping(const Vec3& lo, const Vec3& hi, std::vector<int>& out, std::vector<int>& stack) const;
  /// The ray o + t u (mesh frame, u unit, t in [0, t_max]) against `mesh` (the mesh this query
  /// was built from) through the BVH: the least t, the lowest triangle index on ties; front as
  /// ray_triangle (ray.hpp) says. False when no triangle is met.
  bool cast_ray(const TriangleMesh& mesh, const Vec3& o, const Vec3& u, double t_max, double& t, int& triangle,
                bool& front, std::vector<int>& stack) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The kinds of convex item the narrow phase's dispatch table is indexed by (narrow_phase.cpp).
/// Boxes, hulls and mesh pieces are all polytopes; a box is also flagged (Item::box) for its
/// faster edge axes.
/// Unset marks an item nobody has filled in; the table has no slot for it.
enum class ItemKind : std::uint8_t { Sphere, Capsule, Cylinder, Polytope, Unset };
constexpr int kItemKinds = 4;  ///< the kinds with a row and a column in the table
const char* item_kind_name(ItemKind kind);

/// One convex piece of a body as the pair tests see it: a primitive, or a polytope (a convex mesh
/// or a mesh piece), with its pose and part number (for the feature ids).
struct Item {
  ItemKind kind = ItemKind::Unset;     ///< which of the pointers below holds the geometry
  const Sphere* sphere = nullptr;      ///< exactly one of sphere, capsule, cylinder, polytope is
  const Capsule* capsule = nullptr;    ///< the item's geometry; box and hull are set as well as
  const Cylinder* cylinder = nullptr;  ///< polytope for boxes and hulls (their exact tests)
  const Box* box = nullptr;
  const ConvexHull* hull = nullptr;
  const Polytope* polytope = nullptr;  ///< boxes, hulls and mesh pieces
  Pose pose;
  std::uint32_t part = 0;
  /// A ball that holds the item: centre (world, m) and radius (m), set by items_of. Two items whose
  /// balls are farther apart than the threshold cannot give a contact (the mid phase).
  Vec3 ball_centre = Vec3::Zero();
  double ball_radius = 0.0;
  /// Largest distance of the item's surface from its own origin (m).
  double radius() const;
};

/// The convex items of a bounded shape at pose, appended to items (a Compound's parts, a Mesh's
/// pieces, or the shape itself). A convex Mesh without pieces gets a polytope built into `keep`.
void items_of(const Shape& shape, const Pose& pose, std::vector<Item>& items,
              std::vector<std::shared_ptr<const Polytope>>& keep);

/// A signed distance: gap (m), unit normal A -> B, witness points on A and B (world).
struct Distance {
  double gap;
  Vec3 normal, w_a, w_b;
};

/// A shape's supporting feature along a world direction: a face polygon (with its outward
/// normal), a segment, or a point; world coordinates, with ids (convex_by_support).
struct SupportFeature {
  std::vector<Vec3> points;
  std::vector<FeatureId> ids;
  Vec3 normal = Vec3::Zero();  ///< set for faces
  bool is_face = false;
};

// buffers private to one file, held by Scratch through these pointers
struct PolytopeScratch;  // polytope_contacts.cpp: both polytopes placed in one frame, clip polygons
struct EpaScratch;       // gjk_epa.cpp: the expanding polytope's vertices, faces and horizon
PolytopeScratch* new_polytope_scratch();
EpaScratch* new_epa_scratch();
struct PairMotion;

struct ScratchDeleter {
  void operator()(PolytopeScratch* p) const;
  void operator()(EpaScratch* p) const;
};

/// A face that proved a pair of polytope items apart at the last detection (temporal coherence,
/// lecture 002): the next detection tries that face's axis first, and a pair still separated along
/// it by at least the threshold is done without the full separating-axis test. Any face normal of
/// either polytope bounds the test's own maximum from below, so a stale or mismatched entry can
/// only cost time, never change a result (the key still has to match for it to be tried).
struct SeparatingFace {
  BodyIndex body_a = -1, body_b = -1;  ///< the pair as collide() saw it (A first)
  std::uint32_t part_a = 0, part_b = 0;
  bool of_b = false;                   ///< the face is B's (else A's)
  int face = -1;                       ///< its index in that polytope's faces
  bool operator<(const SeparatingFace& o) const {
    if (body_a != o.body_a) return body_a < o.body_a;
    if (body_b != o.body_b) return body_b < o.body_b;
    if (part_a != o.part_a) return part_a < o.part_a;
    return part_b < o.part_b;
  }
};

/// A body being pushed back out through a triangle of a static mesh it went through (the one-sided
/// mesh's memory of which side the body belongs on): the mesh's body index and the triangle.
struct Crossing {
  BodyIndex mesh = -1;
  int triangle = -1;
};

/// What a triangle-mesh query knows of body B's recent past (the defaults, for a query without a
/// World, know nothing): B's displacement since the start of the previous step (world, m), the
/// triangle of this mesh B was pushed back through last step (-1: none), and, written by the query,
/// the triangle it is pushed back through now (-1: none).
struct TrianglePast {
  Vec3 travel = Vec3::Zero();
  int remembered = -1;
  int found = -1;
  Vec3 body_centre = Vec3::Zero();  ///< B's centre of mass (world, m): a compound's parts cross as one body
  double body_radius = 0.0;         ///< B's bounding radius about it (m); 0: unknown
};

/// The separating-face cache (SeparatingFace): the last detection's entries, sorted by key, and
/// this detection's, written in pair order as they are found.
struct SeparatingCache {
  std::vector<SeparatingFace> last, next;
};

/// A pair's manifold as its last full detection found it, kept so that a pair at rest is not
/// collided again step after step (contact recycling, docs/conventions.md "Contact recycling").
/// Its points keep their rows' lever arms as found (world) and their witness points as material
/// points (each in its own body's frame, the normal in A's), so that a recycled contact's gap is
/// that of the same two points of the bodies now.
struct KeptManifold {
  BodyIndex body_a = -1, body_b = -1;  ///< the pair as collide() saw it (A first)
  Vec3 d0 = Vec3::Zero();              ///< p_B - p_A at the detection (m, world)
  Mat3 R_a0 = Mat3::Identity();        ///< A's orientation then (world from body)
  Mat3 R_b0 = Mat3::Identity();        ///< B's orientation then
  std::uint32_t first = 0, count = 0;  ///< its points: points[first, first + count) of its list
  bool operator<(const KeptManifold& o) const {
    return body_a != o.body_a ? body_a < o.body_a : body_b < o.body_b;
  }
};

/// One point of a KeptManifold.
struct KeptPoint {
  Vec3 on_a = Vec3::Zero();    ///< witness point on A, y - gap/2 n, in A's frame (m)
  Vec3 on_b = Vec3::Zero();    ///< witness point on B, y + gap/2 n, in B's frame (m)
  Vec3 normal = Vec3::Zero();  ///< n (A to B, unit) in A's frame
  Vec3 arm_a = Vec3::Zero();   ///< y - p_A as found (m, world): the rows' lever arm on A
  Vec3 arm_b = Vec3::Zero();   ///< y - p_B as found (m, world)
  FeatureId feature_a = 0, feature_b = 0;
};

/// The kept manifolds: those of the last kept step's detection (sorted by pair, read) and this
/// detection's (written, sorted; they become the last when the step is kept: ContactMemory::commit;
/// a detection run again in the same step, or a step undone, reads the same last ones), each with
/// its points; and how many pairs this detection collided and how many of them kept their manifold.
struct ManifoldCache {
  std::vector<KeptManifold> last, next;
  std::vector<KeptPoint> last_points, next_points;
  int pairs = 0, recycled = 0;
};

/// What lasts from one contact detection to the next, beside the broad phase: the separating-face
/// cache, the kept manifolds, and the static triangle meshes' memory of the bodies (previous_p:
/// each body's centre at the start of the last step, world, m (N); crossing: the triangle each body
/// is being pushed back through (N); crossing_next: the crossings this detection found (N), kept by
/// commit()). A fresh (empty) memory knows nothing: no body has travelled or crossed, no manifold
/// is kept.
struct ContactMemory {
  SeparatingCache separating;
  ManifoldCache manifolds;
  std::vector<Vec3> previous_p;
  std::vector<Crossing> crossing, crossing_next;

  /// Appends a body at centre p (nothing crossed).
  void add_body(const Vec3& p);
  /// Body i was placed at p, not moved there: no travel, no crossing.
  void placed(BodyIndex i, const Vec3& p);
  /// A successful step that started with centres p_start (N): its crossings and kept manifolds
  /// become the memory.
  /// bodies: those whose centres are copied (the non-static ones, ascending; null: all); a static
  /// body's centre changes only by placed().
  void commit(const std::vector<Vec3>& p_start, const std::vector<BodyIndex>* bodies = nullptr);
  /// Drops the bodies with to[i] < 0 and renumbers the rest to to[i], increasing (crossings of
  /// dropped meshes and the kept manifolds of dropped bodies are forgotten); storage stays in place.
  void remove(const std::vector<BodyIndex>& to);
  /// Its part of a saved state: previous centres and crossings, then (from format 5) the kept
  /// manifolds, which decide the next detection's contacts (the separating-face cache is not
  /// saved: it only saves time). load reads n bodies' memory into this (a fresh one) and checks it
  /// against the model: a crossing names a triangle of a TriangleMesh body, centres are finite, a
  /// kept manifold names two bodies and finite points; a save of format `version` below '6' keeps
  /// none (format 5's kept manifolds, without their rows, are read past).
  void save(serial::Writer& w) const;
  void load(serial::Reader& r, const Model& model, char version);
};

/// The pair being collided, as the world knows it (the defaults: a lone pair, nothing known).
struct PairContext {
  BodyIndex body_a = -1, body_b = -1;    ///< the pair as collide() sees it (A first); -1: no bodies
  /// The pair's motion in the step: collide() keeps only the candidates it can close before
  /// choosing the manifold. Null: all kept.
  const PairMotion* motion = nullptr;
  TrianglePast* past = nullptr;          ///< for a TriangleMesh A: B's past, and the crossing found
  /// pair_scale of the two shapes when the caller has their bounding radii (the World's rho), so
  /// that collide() need not walk their vertices; 0: collide() computes it
  double scale = 0.0;
  /// the separating-face cache, used when both bodies are known: the last detection's entries
  /// (read) and where this pair's are appended
  const std::vector<SeparatingFace>* separating_last = nullptr;
  std::vector<SeparatingFace>* separating_next = nullptr;
  /// The same pair seen from B (ids exchanged; the caller swaps the motion).
  PairContext swapped() const;
};

/// Buffers the narrow phase reuses from query to query, and nothing else: the World owns one and
/// hands it to every step, so that contact detection allocates nothing once they have grown to
/// the scene's size; a query without a World (collide() of two shapes) makes its own. One per
/// thread.
struct Scratch {
  Scratch();
  std::vector<double> reach;                           ///< (N) speculative reach per body (m)
  std::vector<std::pair<BodyIndex, BodyIndex>> pairs;  ///< candidate body pairs of the step
  std::vector<Contact> candidates;                     ///< one pair's points before the manifold
  std::vector<int> candidate_index;                    ///< finish_manifold's scratch
  std::vector<Item> items_a, items_b;                  ///< the pair's convex items
  std::vector<int> triangles, bvh_stack;               ///< candidate triangles; BVH traversal
  std::vector<BodyIndex> swept;                        ///< bodies along a sweep (continuous collision)
  std::vector<BodyIndex> mechanism;                    ///< a body put back and those its joints link it to (continuous collision)
  std::vector<char> on_static;  ///< by body: the step's contacts have it against a static body (continuous collision)
  std::vector<BodyIndex> walls;               ///< continuous collision: the static bodies a body's path meets
  std::vector<double> start_depth, end_depth; ///< continuous collision: its depth in each at its path's ends (m)
  std::vector<Contact> wall_contacts;         ///< continuous collision: one wall's manifold (scratch)
  std::vector<const void*> tree_stack;                 ///< the broad phase's walk for them
  Polytope triangle;                                   ///< the current triangle as a polytope
  SupportFeature feature_a, feature_b;                 ///< convex_by_support: both features
  std::vector<std::pair<Vec3, std::pair<FeatureId, FeatureId>>> clip, clip_next;  ///< and its clip
  std::unique_ptr<PolytopeScratch, ScratchDeleter> polytope;
  std::unique_ptr<EpaScratch, ScratchDeleter> epa;
  /// generate_contacts on several threads: the pairs cut into chunks of kPairsPerChunk, each
  /// chunk's pairs found anew written apart (contacts, separating faces, crossings, kept
  /// manifolds) and joined in pair order; the threads' own buffers (by oneTBB thread index)
  struct PairChunk {
    std::vector<Contact> contacts;
    std::vector<SeparatingFace> separating;
    std::vector<std::pair<BodyIndex, Crossing>> crossings;
    std::vector<KeptManifold> kept;
    std::vector<KeptPoint> kept_points;
    int recycled = 0;
  };
  std::vector<PairChunk> chunks;
  /// Per candidate pair, on several threads: the kept manifold it recycles (its index in the last
  /// ones; -1: found anew), its contacts' count and where they go in the step's list, and where
  /// its kept points come from (the last points, or its chunk's) and go
  struct PairPlace {
    int last = -1;
    std::uint32_t count = 0, points = 0, points_from = 0;
    std::size_t at = 0, points_at = 0;
  };
  std::vector<PairPlace> places;
  std::vector<std::unique_ptr<Scratch>> workers;
};

/// s.workers grown to `threads` scratches (kept from step to step), for work split over a pool of
/// that many threads; worker_scratch: the calling thread's (by its slot in the pool's arena).
void grow_workers(Scratch& s, std::size_t threads);
Scratch& worker_scratch(Scratch& s, std::size_t threads);

/// What a narrow-phase query may use besides the two shapes: the triangle queries of static
/// triangle meshes (null: built on the spot) and scratch buffers (null: made for the query).
struct Services {
  const TriangleQuery* triangles_a = nullptr;
  const TriangleQuery* triangles_b = nullptr;
  Scratch* scratch = nullptr;
};

/// A mesh that can only collide with planes: not decomposed, and non-convex or open.
bool is_bare_nonconvex_mesh(const Shape& s);

/// Empty when the narrow phase can collide shapes a and b; otherwise why not ("unsupported pair
/// ..."). Pairs of static-only shapes count as supported: both are static and never collide.
/// Only a pair with a bare non-convex mesh (is_bare_nonconvex_mesh) is unsupported.
std::string unsupported_pair(const Shape& a, const Shape& b);

/// The contact manifold of shape a at pose_a (A) and shape b at pose_b (B): up to 4 contacts with
/// gap < threshold (m), normals A -> B, feature ids, in id order (docs/conventions.md,
/// "Manifolds"); body_a and body_b are left at -1. Appended to out. A static-only shape (Plane,
/// TriangleMesh) must be a. Throws std::invalid_argument for an unsupported pair.
/// pair: who the two shapes are to the world (the pair's motion, the meshes' memory, the cache).
void collide(const Shape& a, const Pose& pose_a, const Shape& b, const Pose& pose_b, double threshold,
             const Services& services, std::vector<Contact>& out, const PairContext& pair = PairContext());

/// Length scale L of a pair (sum of the bounding radii of its bounded shapes), for the relative
/// tolerances of the manifold rules.
double pair_scale(const Shape& a, const Shape& b);
/// The same, given the shapes' bounding radii (the World's rho): no walk over their vertices.
double pair_scale(const Shape& a, double rho_a, const Shape& b, double rho_b);

/// Candidates -> manifold (docs/conventions.md, "Manifolds"): drops gap >= threshold, sorts by
/// (feature_a, feature_b), drops duplicates within 1e-9 L, reduces more than 4 to 4 by area,
/// ranking the points by the gap they close to in the step (PairMotion::end_gap; collide() gives
/// the motion against a plane only) or, without a motion, by their gaps; the touching points, from
/// which the rules take p2 to p4 first, end within max(e_1, min(0, n . k + kTouchInnerFraction
/// inner)) of the plane, e_1 the deepest end gap and k = dt^2 g_rel gravity's kick (with no
/// motion: max(e_1, 0)). The result is appended to out; index is scratch (the candidates' indices
/// while the rules run).
void finish_manifold(std::vector<Contact>& candidates, double threshold, double L, std::vector<Contact>& out,
                     std::vector<int>& index, const PairMotion* motion = nullptr);

// ---- pair tests (append candidates in world frame, normal A -> B) ----

/// Plane (A) against any bounded shape B.
void plane_contacts(const Plane& plane, const Pose& pa, const Shape& b, const Pose& pb, double threshold,
                    Scratch& scratch, std::vector<Contact>& out);

/// Contact of two rounded points: core points x_a, x_b (world) with radii r_a, r_b; normal along
/// x_b - x_a (n_hint where they coincide), gap |x_b - x_a| - r_a - r_b, point midway between the
/// surface witnesses. Spheres, and capsules as rounded segments, are all this.
Contact rounded_contact(const Vec3& x_a, double r_a, const Vec3& x_b, double r_b, const Vec3& n_hint,
                        FeatureId fa, FeatureId fb);

/// Exact sphere-sphere contact, one candidate.
void sphere_sphere(const Vec3& c_a, double r_a, const Vec3& c_b, double r_b, std::vector<Contact>& out);

/// A convex item (A) against a sphere (B), exact (closest point): boxes, capsules and cylinders by
/// their closed forms, hulls and mesh pieces over their faces.
void item_sphere(const Item& a, const Vec3& c, double r, std::vector<Contact>& out);

/// The plane n . x = offset (world, A) against item B: sphere, box corners, capsule ends,
/// cylinder rims, hull and piece vertices.
void plane_item(const Vec3& n, double offset, const Item& b, std::vector<Contact>& out);

/// Two convex polytopes (boxes, hulls, mesh pieces) by separating axes and face clipping; an edge
/// axis that wins for polytopes apart, with the edges' closest line points off the edges, gives
/// their closest pair instead (docs/conventions.md, "Manifolds", edge contact), and so does a face
/// clip of polytopes apart or touching that misses it (keeps nothing, or only points farther than it
/// by more than 1e-9 L: the pair is added to them), so that the deepest gap is the distance.
/// boxes: both are box polytopes (geometry::box_polytope's numbering), whose edge axes are then
/// found among 18 candidate pairs rather than all 144, with the same result.
/// separated, optional: set to the face (of_b, face) whose axis separated the pair by at least the
/// threshold when that is why no contact was made; face = -1 otherwise.
/// motion, optional: the pair's (A, B, the bodies a and b belong to); contacts it cannot close
/// (PairMotion::can_close) may then be left out, and the tests stop where none can be: those it
/// can close are the same (the separating face may be set where the threshold alone would not).
void polytope_polytope(const Polytope& a, const Pose& pa, std::uint32_t part_a, const Polytope& b,
                       const Pose& pb, std::uint32_t part_b, double threshold, PolytopeScratch& scratch,
                       std::vector<Contact>& out, bool boxes = false, SeparatingFace* separated = nullptr,
                       const PairMotion* motion = nullptr);

/// The threshold polytope_polytope runs its tests to given the pair's motion (m): no contact the
/// motion can close lies at or beyond it (boxes: as there).
double polytope_threshold(const Polytope& a, const Pose& pa, const Polytope& b, const Pose& pb, bool boxes,
                          double threshold, const PairMotion& motion);

/// The separation of polytope b from a along face f of a (world poses): min over b's vertices of
/// n_f . x - offset_f, the value of that face in the separating-axis test.
double face_separation(const Polytope& a, const Pose& pa, int f, const Polytope& b, const Pose& pb);

/// One triangle of a static mesh (as a two-faced polytope, A) against a polytope B: one-sided
/// separating axes (its front face, B's faces, edge axes from its active edges only), clipping
/// that drops cuts along inactive edges; an edge axis off the edges, or a clip that misses the
/// closest pair, for a B apart (or touching) gives the closest pair of the triangle and B, as for
/// two polytopes (it may be a ghost, which the caller replaces). Features of A carry the triangle
/// index as part.
/// face_only: the triangle's face is the reference, whatever the other axes say, and no closest pair
/// is added (the face's own contact, which replaces a ghost of an inactive edge).
void triangle_polytope(const Polytope& tri, const std::array<bool, 3>& active, const Pose& pa,
                       std::uint32_t triangle, const Polytope& b, const Pose& pb, std::uint32_t part_b,
                       double threshold, PolytopeScratch& scratch, std::vector<Contact>& out,
                       bool face_only = false);

/// Capsule (segment p0 p1, radius r) against capsule, exact; 2 points when parallel and overlapping.
void capsule_capsule(const Capsule& a, const Pose& pa, std::uint32_t part_a, const Capsule& b,
                     const Pose& pb, std::uint32_t part_b, double threshold, std::vector<Contact>& out);

/// Polytope (A) against capsule (B): exact distance (or separating axes when the segment enters
/// the polytope), the segment clipped to the face it lies on.
void polytope_capsule(const Polytope& a, const Pose& pa, std::uint32_t part_a, const Capsule& b,
                      const Pose& pb, std::uint32_t part_b, double threshold, std::vector<Contact>& out);

/// The contact test of item A against item B: the slot of the dispatch table for their kinds
/// (narrow_phase.cpp). Appends candidate contacts (normal from A to B) to out. A pair of kinds
/// without a test throws std::logic_error naming both kinds.
/// pair: the bodies and the separating-face cache (polytope pairs only).
void contact_items(const Item& a, const Item& b, double threshold, Scratch& scratch, std::vector<Contact>& out,
                   const PairContext& pair = PairContext());

/// The supporting feature of item `it` along world direction dir, written into s: a face (a
/// polytope face, or a cylinder's cap as 8 rim points, within ~5.7 degrees of dir), a segment (a
/// cylinder's side within ~11.5 degrees of square to dir, a capsule's within 5.7), or a point.
void support_feature(const Item& it, const Vec3& dir, SupportFeature& s);

/// Two supporting features with no face (sa of A, sb of B, along the normal n from A to B), at
/// least one a straight side (a segment: a cylinder's side within ~11.5 degrees of square to n, a
/// capsule's within 5.7), the other a side too or a polytope's vertex whose edge serves as one, lying along
/// each other (within ~11.5 degrees in the plane square to n): appends a contact at each end of
/// their overlap along the side with gap n . (x_B - x_A) < threshold (m) and returns true; false
/// (nothing appended) otherwise, where the distance's single point serves.
bool side_on_side(const Item& a, const Item& b, const SupportFeature& sa, const SupportFeature& sb, const Vec3& n,
                  double threshold, std::vector<Contact>& out);

/// The incident feature `inc` clipped by the side planes of the reference face `ref` (a face:
/// points counter-clockwise about ref.normal, seen from outside), each kept point q with
/// gap = ref.normal . (q - ref.points[0]) < threshold a contact at q - gap/2 ref.normal, its normal
/// ref.normal when the reference is A's (ref_is_a), else reversed. Parts name the ids' owners.
void clip_features(const SupportFeature& ref, const SupportFeature& inc, bool ref_is_a, std::uint32_t ref_part,
                   std::uint32_t inc_part, double threshold, Scratch& scratch, std::vector<Contact>& out);

/// Any two items without a closed-form test (a cylinder against a box, hull, capsule, cylinder or
/// triangle): the signed distance by GJK / EPA on the support mappings (gjk_epa.hpp), then the
/// supporting features of both along its normal clipped against each other (a face against
/// whatever faces it), or the single pair of support points.
void convex_by_support(const Item& a, const Item& b, double threshold, Scratch& scratch, std::vector<Contact>& out);
/// The same with their signed distance already known (gjk_epa(a, b)).
void convex_by_support(const Item& a, const Item& b, const Distance& dist, double threshold, Scratch& scratch,
                       std::vector<Contact>& out);

/// Static triangle mesh (A) against item B: candidate triangles from the BVH, a convex test per
/// triangle (inactive edges give no edge contacts), merged. A B that has gone through a triangle
/// (its centre behind the face, inside its prism, and either still straddling the face, or in front
/// of it at the start of the previous step, or pushed back through it last step: past) is pushed
/// back out along the face normal instead; past.found names that triangle.
void trimesh_item(const TriangleMesh& a, const Pose& pa, const TriangleQuery& query, const Item& b,
                  double threshold, TrianglePast& past, Scratch& scratch, std::vector<Contact>& out);

/// Triangle t of the mesh as a two-faced polytope in P (front loop 0 1 2, back 0 2 1; edges 0->1,
/// 1->2, 2->0), mesh frame (trimesh_contacts.cpp).
void triangle_polytope_of(const TriangleMesh& mesh, Eigen::Index t, Polytope& P);

/// The first touch of a translational sweep (cast.cpp): t in [0, 1] (the fraction of the
/// translation), the normal from the fixed shape to the moving one (unit, world) and a point
/// between the two (world, m) at that t; hit false when the sweep never comes that close.
struct CastHit {
  bool hit = false;
  double t = 1.0;
  Vec3 normal = Vec3::Zero();
  Vec3 point = Vec3::Zero();
};

/// The least t in [0, 1] at which convex item b, moved by t delta (world, m), comes within target
/// (m) of item a: conservative advancement on gjk_epa's distances (Newton steps on the gap, which
/// is convex in t, from below: never past the touch), to 1e-12 of (the items' radii + |delta|)
/// above the target; t = 0 when they start within it.
CastHit cast_item(const Item& a, const Item& b, const Vec3& delta, double target, EpaScratch& epa);

/// Bounded shape `moving` at pose_b, translated by t delta, against shape `fixed` at pose_a (any
/// kind: a plane exactly, a triangle mesh one-sided: each triangle whose front the item starts in
/// front of and moves towards; triangles: its query, null: built here): the earliest hit over their
/// convex item pairs (cast_item). Uses s.items_a, items_b, triangles, bvh_stack, triangle, epa.
CastHit cast_shape(const Shape& fixed, const Pose& pose_a, const Shape& moving, const Pose& pose_b, const Vec3& delta,
                   double target, const TriangleQuery* triangles, Scratch& s);

/// Candidate pairs from bounding volumes. Holds FCL objects for the non-plane bodies: static ones in
/// a DynamicAABBTree built once, awake dynamic ones in a second one refitted each step, sleeping ones
/// in a third one (their frozen boxes, refitted only when the margin changes). A step's work grows
/// with the awake bodies and their pairs, not with the static or sleeping ones.
class BroadPhase {
 public:
  BroadPhase();
  ~BroadPhase();
  /// Registers body i (after the Model has it). Planes are not registered (they are unbounded and
  /// tested against every dynamic body directly). Its leaves enter the trees at the next pairs() or
  /// refresh(), together with every body added before it (a balanced build, not a chain of inserts);
  /// cast_ray and overlap_box need one of those first.
  void add_body(BodyIndex i, const Shape& shape, bool is_static, const Vec3& p, const Mat3& R);
  /// Moves static body i (rare; rebuilds its tree entry).
  void move_static(BodyIndex i, const Vec3& p, const Mat3& R);
  /// Pairs (i, j), i < j, whose AABBs, grown by reach[i] + margin/2 and reach[j] + margin/2,
  /// overlap; at least one of them dynamic and awake (state.asleep: sleeping bodies sit in a tree
  /// of their own, neither refitted nor collided with each other or with static bodies; a body
  /// moves between the trees as it falls asleep or wakes, allocating nothing: it is registered in
  /// both once, parked far away in the one it is not in); planes excluded. Sorted
  /// lexicographically, written into out (cleared first; its capacity is reused). The awake
  /// bodies' boxes are computed on pool's threads (null: the calling thread alone).
  void pairs(const Model& model, const State& state, const std::vector<double>& reach, double margin,
             std::vector<std::pair<BodyIndex, BodyIndex>>& out, const parallel::Pool* pool = nullptr);
  /// The triangle query of body i if it is a TriangleMesh, else null.
  const TriangleQuery* triangles(BodyIndex i) const;
  /// The bodies whose shape is a Plane (not in either tree), ascending.
  const std::vector<BodyIndex>& planes() const;

  // ---- queries (world/queries.cpp): the trees walked by a ray or a box, never a scan ----
  /// Makes every tree box hold its body's current pose (poses set between steps, bodies that fell
  /// asleep after the last pairs()): awake dynamic boxes tight (pairs() regrows them), sleeping
  /// and static ones grown as pairs() grew them, so that the next step's pairs are unchanged.
  void refresh(const Model& model, const State& state);
  /// What a ray's walk of the trees calls for each body whose box the ray meets within its bound:
  /// visit(i, bound) returns the new bound (m; the closest hit so far, or bound itself to see
  /// every body), or a negative number to stop the walk.
  struct RayVisitor {
    virtual double visit(BodyIndex i, double bound) = 0;
  };
  /// The ray o + t u (world, u unit) for t in [0, bound] through the static, awake and sleeping
  /// trees (planes excluded). nodes counts the tree boxes tested. Thread-safe between refreshes.
  void cast_ray(const Vec3& o, const Vec3& u, double bound, RayVisitor& visitor, std::vector<const void*>& stack,
                std::int64_t& nodes) const;
  /// The bodies whose tree boxes overlap [lo, hi] (world, m), appended to out in tree order
  /// (planes excluded); statics_only: the static tree's alone (a body's being static is fixed when
  /// it is added), which skips walking the moving bodies' trees.
  void overlap_box(const Vec3& lo, const Vec3& hi, std::vector<BodyIndex>& out, std::vector<const void*>& stack,
                   std::int64_t& nodes, bool statics_only = false) const;
  /// Within a step, after pairs(): the pairs (i, j), i < j, of at least one body of `escaped`
  /// (ascending: awake dynamic bodies whose surface has moved further since the step's start than
  /// pairs() was given as their reach) whose boxes at `now`, grown by reach[i] + margin/2 and
  /// reach[j] + margin/2, overlap (planes excluded), sorted, appended to out (cleared first).
  /// Every other body is inside the leaf pairs() gave it (it stayed within its reach), so the
  /// trees are walked (overlap_box) with an escaped body's grown box grown once more by the
  /// largest reach + margin/2 (reach_bound) and the bodies met are tested with their boxes at
  /// `now`; escaped bodies are tested against each other directly (their leaves are out of date).
  /// reach (N, m): each body's reach from `now` (body_reach for the rest of the step). met, stack:
  /// the walks' buffers.
  void escaped_pairs(const Model& model, const State& now, const std::vector<BodyIndex>& escaped,
                     const std::vector<double>& reach, double reach_bound, double margin,
                     std::vector<std::pair<BodyIndex, BodyIndex>>& out, std::vector<BodyIndex>& met,
                     std::vector<const void*>& stack) const;

 private:
  /// Sets every static body's box from its pose, grown by margin/2, and refits the static tree.
  void refit_static(const Model& model, const State& state, double margin);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Speculative reach of every body for a step of dt: s_b = dt (|v| + dt |g| + |omega| rho) for a
/// dynamic body, 0 for a static or sleeping one (m); written into reach (sized N). bodies: the
/// bodies to write (the World's non-static ones, ascending); null: all. The others' entries stay
/// as they are: 0 (set so when reach is sized to N).
void speculative_reach(const Model& model, const State& state, double dt, const Vec3& gravity,
                       std::vector<double>& reach, const std::vector<BodyIndex>* bodies = nullptr);

/// Which points one body pair can close in this step: those with gap < margin, and the speculative
/// ones with gap < margin + dt (u + dt (g_n + (|omega_A|^2 rho_A + |omega_B|^2 rho_B) / 2)),
/// u = max(0, -n . (v_B(y) - v_A(y))) the approach speed at the point y (v_i(y) = v_i + omega_i x
/// (y - p_i)), g_n = max(0, -n . (g_B - g_A)) the approach by gravity (g_i = g for a body gravity
/// moves, else 0), and the last term the turn of a spinning body's surface towards n beyond first
/// order (its centripetal acceleration is at most |omega|^2 rho). The body-wide reach of the broad
/// phase bounds every point of a body by its fastest one; this bounds each point by its own motion,
/// so a spinning body keeps no speculative contacts with neighbours its surface does not move
/// towards. collide() drops the points a pair cannot close before it reduces the manifold to 4
/// (PairContext::motion), so a far speculative point never takes the place of one that holds.
struct PairMotion {
  PairMotion() = default;  ///< nothing moves: fields set one by one (tests)
  /// The pair (a, b) as collide() sees it (A first), at `state`, for a step of dt s.
  PairMotion(const Model& model, const State& state, BodyIndex a, BodyIndex b, double dt, const Vec3& gravity,
             double margin);
  /// The same pair seen from B (collide() swaps a static-only B to A).
  PairMotion swapped() const;
  /// True if the pair can close c (normal A -> B, world frame) in this step: at their approach
  /// speed at c, or at one body's own when the other, a dynamic body, is stopped by a third within
  /// the step (a stack falling as one closes its gaps when its lowest body lands).
  bool can_close(const Contact& c) const;
  /// The gap of c at the end of the step if the point moves on at its velocity after gravity's
  /// kick: gap + dt n . (v_B(y) - v_A(y) + dt g_rel) (m), y = c.point (the manifold's ranking).
  double end_gap(const Contact& c) const;
  /// v_B(y) - v_A(y), the velocity of B's point y relative to A's (world, m/s).
  Vec3 relative_velocity(const Vec3& y) const;
  /// A gap (m) that no contact can_close keeps reaches, whatever its normal, for contacts whose
  /// point y lies within r_a of A's centre and r_b of B's (m): margin + dt (u + dt turning), u the
  /// largest closing speed can_close can find there (each velocity's norm, |omega_i| r_i for the
  /// spins). Up to rounding: callers add a slack.
  double closable_gap(double r_a, double r_b) const;
  /// The same for the contacts whose normal n (A -> B, world) lies in the cone n . k >= c (k unit,
  /// 0 <= c <= 1): each velocity's largest component over the cone instead of its norm. A pair of
  /// convex shapes separated by s along k has every contact nearer than t in that cone for c = s / t
  /// (n . (q - p) >= s for any points p of A and q of B), at a gap of at least s.
  double closable_gap(double r_a, double r_b, const Vec3& k, double c) const;

  Vec3 p_a = Vec3::Zero(), v_a = Vec3::Zero(), omega_a = Vec3::Zero();  ///< A's centre (m), velocity (m/s), spin (rad/s)
  Vec3 p_b = Vec3::Zero(), v_b = Vec3::Zero(), omega_b = Vec3::Zero();  ///< B's
  Vec3 g_rel = Vec3::Zero();  ///< g_B - g_A (m/s^2)
  Vec3 g_a = Vec3::Zero(), g_b = Vec3::Zero();  ///< g_i: gravity for a body gravity moves, else 0 (m/s^2)
  bool stoppable_a = false, stoppable_b = false;  ///< dynamic: another contact can stop it within the step
  double turning = 0.0;  ///< (|omega_A|^2 rho_A + |omega_B|^2 rho_B) / 2 (m/s^2)
  double dt = 0.0, margin = 0.0;
  double inner = 0.0;  ///< the smaller inner radius of the pair's bodies (m; a plane's is infinite)
};

/// The manifold's touching tolerance counts gravity's kick dt^2 g over the step (PairMotion::end_gap)
/// up to this fraction of the pair's smaller inner radius (finish_manifold; docs/conventions.md,
/// "Manifolds"): at dt 1/60 the kick is 2.7 mm, and a body thinner than that, resting, had every
/// vertex touching.
constexpr double kTouchInnerFraction = 0.2;

/// Speculative reach of body b towards a plane of world normal n: only the approach speed counts,
/// dt (max(0, -n . v) + dt max(0, -n . g) + turn_speed) (m), so a body sliding along a plane does
/// not gather contacts it cannot reach.
double plane_reach(const Model& model, const State& state, BodyIndex b, const Vec3& n, double dt,
                   const Vec3& gravity);

/// The contacts detected at state `detected`, carried to state `now` by the motion of their bodies
/// (a substep, docs/conventions.md "One step"), to first order, as the velocity constraint
/// linearises it: with each body's displacement dp = p - p_0 and turn dtheta = vee of the skew part
/// of R R_0^T, and the witness points w_A = y - gap/2 n, w_B = y + gap/2 n,
/// gap <- gap + n . ((dp_B + dtheta_B x (w_B - p_B0)) - (dp_A + dtheta_A x (w_A - p_A0))),
/// but a round side (rounding_radius rho > 0) carries its core c_B = w_B + rho_B n (c_A = w_A -
/// rho_A n) with the whole turn, dp + (R R_0^T - I) (c - p_0), since its witness stays under the
/// core however the body turns (a rolling ball keeps its gap; a spinning capsule's end cap follows
/// its core). The normal stays; the lever arms stay as detected: anchor_X = y + dp_X (or, given
/// the contacts' anchors at `detected`, from_a and from_b (K), anchor_X = from_X + dp_X, and the
/// witnesses taken from them, w_A = from_A - gap/2 n, w_B = from_B + gap/2 n; a kept contact's
/// anchor is p_X + arm_X), where the solver applies the force on X (K, world, m); y <- (anchor_a +
/// anchor_b) / 2. Written into out, contact by contact over the threads of `pool` (null: the
/// calling thread alone; the same bits either way).
void carry_contacts(const Model& model, const std::vector<Contact>& at_detection, const State& detected,
                    const State& now, std::vector<Contact>& out, std::vector<Vec3>& anchor_a,
                    std::vector<Vec3>& anchor_b, const std::vector<Vec3>* from_a = nullptr,
                    const std::vector<Vec3>* from_b = nullptr, const parallel::Pool* pool = nullptr);

/// A pair of the PGS step is collided again in a substep once its bodies' turns since the step's
/// detection have moved their points more than this fraction of its smaller inner radius
/// (turned_far, redetect_turned): contacts carried along stop describing a turning corner long
/// before it has turned through a face (docs/conventions.md, "Deep overlaps"). A step whose
/// contacts turn faster takes substeps short enough that each turns a pair by at most as much
/// (World::turn_substeps), at most kTurnSubsteps of them per 1/kTurnRate s of the step (begun) or
/// kTurnSubstepFactor times the count its own rule gives, whichever is more: 16 at dt 1/1000 and
/// 1/240, 64 at 1/60, with either solver (World::turn_budget).
constexpr double kTurnReach = 0.25;
constexpr int kTurnSubsteps = 16;
constexpr double kTurnRate = 240.0;
constexpr int kTurnSubstepFactor = 4;

/// True when candidate pair (a, b) has turned far: turned[a] + turned[b] > kTurnReach min(inner_a,
/// inner_b), turned (N) how far each body's turn has moved its points (m). Never for a pair with a
/// sensor (its pairs are never solved: World::split_sensors takes them out).
inline bool turned_far(const Model& model, BodyIndex a, BodyIndex b, const std::vector<double>& turned) {
  return turned[a] + turned[b] > kTurnReach * std::min(model.inner[a], model.inner[b]) && !model.is_sensor[a] &&
         !model.is_sensor[b];
}

/// True when some candidate pair of `pairs` has turned far (turned_far).
bool any_turned(const Model& model, const std::vector<std::pair<BodyIndex, BodyIndex>>& pairs,
                const std::vector<double>& turned);

/// The step's contacts in a substep after some pairs have turned far since the detection
/// (turned_far; docs/conventions.md, "Deep overlaps": a body's rows aim where its contacts were
/// found, and a turn moves a corner's contact off its face), or some body has escaped (moved
/// further than the detection's reach for it: BroadPhase::escaped_pairs): the pairs of the step's
/// candidate list scratch.pairs (as the last generate_contacts left it) that have turned far are
/// collided again at `now`, as a detection at `now` for a step of dt would (dt: what is left of
/// the step; speculative reach from now's velocities: body_reach; no memory written), their
/// contacts' anchors at their points; so are the pairs of `extra` that carry no contact (null:
/// none; sorted candidate pairs of the escaped bodies at `now`, some new to the step, whose boxes
/// meet there; the caller may leave out those that carry contacts, and leaves out those
/// model.can_collide refuses, a sensor's and a sleeping body's). The other pairs' carried contacts and anchors (carried, carried_a,
/// carried_b: carry_contacts's, in pair order) are copied. Written into out, anchor_a, anchor_b,
/// in pair order. turned (N): how far each body's turn has moved its points (m).
void redetect_turned(const Model& model, const State& now, double dt, const Vec3& gravity, double margin,
                     const BroadPhase& broad_phase, const ContactMemory& memory, Scratch& scratch,
                     const std::vector<double>& turned, const std::vector<Contact>& carried,
                     const std::vector<Vec3>& carried_a, const std::vector<Vec3>& carried_b, std::vector<Contact>& out,
                     std::vector<Vec3>& anchor_a, std::vector<Vec3>& anchor_b,
                     const std::vector<std::pair<BodyIndex, BodyIndex>>* extra = nullptr);

/// The speed (m/s) at which a body turning at |omega| (rad/s) can move its surface over a step of
/// dt towards another, with bounding radius rho (m): |omega| rho, but a turn moves no point
/// further than 2 rho, so at most 2 rho / dt (a capsule spun at 1,000 rad/s reaches 2 rho in a
/// step, not 17 rho at dt 1/60).
inline double turn_speed(double omega, double rho, double dt) { return std::min(omega * rho, 2.0 * rho / dt); }

/// How far body i's surface can travel in a step of dt (m): dt (|v| + dt |g| + turn_speed), 0
/// for a static or sleeping body.
double body_reach(const Model& model, const State& state, BodyIndex i, double dt, const Vec3& gravity);

/// Contact generation: all contacts for the current state, in the order of docs/conventions.md,
/// written into out (cleared first), using and growing the scratch buffers. Only pairs that
/// model.can_collide allows (enabled bodies, matching filter bits, not excluded, not two infinite
/// masses), and none where nothing moves: a sleeping body (state.asleep) against a sleeping, static
/// or still kinematic one (a sleeping body's speculative reach is 0). memory: read (previous
/// centres, crossings; empty: nothing remembered) and written (the separating-face cache; this
/// detection's crossings to memory.crossing_next). bodies: the bodies that can move (the World's
/// non-static ones, ascending; null: all), the only ones whose per-body entries (reach, crossings)
/// are written, so that a detection's cost grows with them and the pairs, not with static bodies.
/// recycle (m): a pair of shapes that recycle (recycles()) whose manifold is kept in memory
/// keeps it (its rows as found, its gaps carried with its bodies) while its drift (pair_drift:
/// how far B's centre has moved relative to A's plus how far each body's turn has moved its
/// points, counting the step's motion at the current velocities) is at most min(recycle,
/// kRecycleInnerFraction times the smaller inner radius) (docs/conventions.md, "Contact
/// recycling"); 0: every pair is collided anew. The kept manifolds are written to memory.manifolds.
void generate_contacts(const Model& model, const State& state, double dt, const Vec3& gravity, double margin,
                       BroadPhase& broad_phase, ContactMemory& memory, Scratch& scratch, std::vector<Contact>& out,
                       const parallel::Pool* pool = nullptr, const std::vector<BodyIndex>* bodies = nullptr,
                       double recycle = 0.0);

/// A recycled pair's drift is at most this fraction of the smaller inner radius (so a small
/// body's manifold is found again sooner than a large one's): 5 cm for a unit cube, Box3D's
/// recycle distance (10 linear slops).
constexpr double kRecycleInnerFraction = 0.1;

/// True for a pair of shapes whose manifold may be kept: both bodies' shapes are polytopes, hulls,
/// cylinders, capsules or compounds (their narrow phase costs a separating-axis test or GJK and a
/// clip); a sphere, plane or triangle mesh in the pair is collided every step (a sphere's or
/// plane's query costs less than the check, and a triangle mesh keeps its own memory of crossings).
bool recycles(const Shape& a, const Shape& b);

}  // namespace signorini::collision
