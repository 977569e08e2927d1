// Saved states as flat little-endian byte strings: a Writer that appends plain values and Eigen
// matrices, and a Reader that reads them back, refusing truncated input and counts the rest of the
// input cannot hold. Each owner of saved data (World, State, solver, contact memory) writes and
// reads its own part with these.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

namespace signorini::serial {

struct Writer {
  std::string out;
  template <class T>
  void pod(const T& x) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&x), sizeof(T));
  }
  /// A fixed-size matrix's doubles, column-major.
  template <class M>
  void mat(const M& x) {
    for (Eigen::Index k = 0; k < x.size(); ++k) pod(x.data()[k]);
  }
  template <class M>
  void mats(const std::vector<M>& xs) {
    for (const M& x : xs) mat(x);
  }
};

struct Reader {
  const std::string& in;
  std::size_t at = 0;
  template <class T>
  T pod() {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in.size() - at < sizeof(T)) throw std::invalid_argument("restore_state: the saved state is truncated");
    T x;
    std::memcpy(&x, in.data() + at, sizeof(T));
    at += sizeof(T);
    return x;
  }
  template <class M>
  void mat(M& x) {
    for (Eigen::Index k = 0; k < x.size(); ++k) x.data()[k] = pod<double>();
  }
  /// n matrices into xs (resized).
  template <class M>
  void mats(std::vector<M>& xs, std::size_t n) {
    xs.resize(n);
    for (M& x : xs) mat(x);
  }
  /// A count of items of at least `bytes` each that the rest of the input can hold.
  std::size_t count(std::size_t bytes) {
    const auto n = pod<std::uint64_t>();
    if (n > (in.size() - at) / bytes) throw std::invalid_argument("restore_state: the saved state is damaged");
    return static_cast<std::size_t>(n);
  }
};

}  // namespace signorini::serial
