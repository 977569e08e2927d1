// The solver's part of a saved state (contact_solver.hpp, save and load).
#include "serial/byte_stream.hpp"
#include "solver/contact_solver.hpp"

namespace signorini::solver {

void save_cache(serial::Writer& w, const std::vector<CachedContact>& cache) {
  w.pod(static_cast<std::uint64_t>(cache.size()));
  for (const CachedContact& c : cache) {
    w.pod(c.body_a);
    w.pod(c.body_b);
    w.pod(c.feature_a);
    w.pod(c.feature_b);
    w.pod(c.alpha);
    w.mat(c.friction);
    w.pod(c.spin);
    w.pod(c.order);
  }
}

void load_cache(serial::Reader& r, char version, std::vector<CachedContact>& cache) {
  cache.resize(r.count(sizeof(CachedContact::alpha)));
  for (CachedContact& c : cache) {
    c.body_a = r.pod<BodyIndex>();
    c.body_b = r.pod<BodyIndex>();
    c.feature_a = r.pod<FeatureId>();
    c.feature_b = r.pod<FeatureId>();
    c.alpha = r.pod<double>();
    r.mat(c.friction);
    if (version >= '2') c.spin = r.pod<double>();
    c.order = r.pod<int>();
  }
}

void save(serial::Writer& w, const SolverData& data) {
  w.mats(data.body_force);
  w.mats(data.body_torque);
  save_cache(w, data.cache);
}

void load(serial::Reader& r, char version, std::size_t n, SolverData& out) {
  r.mats(out.body_force, n);
  r.mats(out.body_torque, n);
  load_cache(r, version, out.cache);
}

}  // namespace signorini::solver
