// The wire format of a rank's share of an MPI batch (rom/detail/share_wire.hpp), and the checkpoint path of a rank.
#include "rom/detail/share_wire.hpp"

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "rom/outcome.hpp"

namespace mpmrom {
namespace {

// Values as they lie in memory; vectors and strings after their length.
class ShareWriter {
 public:
  template <class T>
  void value(const T& v) {
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void doubles(const std::vector<double>& v) {
    value(std::uint64_t(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
  }
  void text(const std::string& t) {
    value(std::uint64_t(t.size()));
    bytes_ += t;
  }
  void field(const std::string& t) { text(t); }
  template <class T>
  void field(const T& v) {
    value(v);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ShareReader {
 public:
  explicit ShareReader(const std::string& bytes) : bytes_(bytes) {}
  template <class T>
  T value() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  void append_doubles(std::vector<double>& out) {
    const auto n = std::size_t(value<std::uint64_t>());
    const std::size_t old = out.size();
    out.resize(old + n);
    take(out.data() + old, n * sizeof(double));
  }
  std::string text() {
    std::string t(std::size_t(value<std::uint64_t>()), '\0');
    take(t.data(), t.size());
    return t;
  }
  void field(std::string& t) { t = text(); }
  template <class T>
  void field(T& v) {
    v = value<T>();
  }

 private:
  void take(void* to, std::size_t n) {
    if (n > bytes_.size() - at_) throw std::runtime_error("MPI: a rank's rollout results arrived incomplete");
    std::memcpy(to, bytes_.data() + at_, n);
    at_ += n;
  }
  const std::string& bytes_;
  std::size_t at_ = 0;
};

}  // namespace

std::string impl::share_bytes(const RomResult& share) {
  ShareWriter w;
  w.doubles(share.xhat);
  w.doubles(share.xhatdot);
  w.value(std::uint64_t(share.outcomes.size()));
  for (const auto& o : share.outcomes)
    impl::for_each_outcome_field([&](const auto& field) { w.field(o.*field.member); });
  return w.bytes();
}

void impl::append_share(RomResult& whole, const std::string& bytes) {
  ShareReader in(bytes);
  in.append_doubles(whole.xhat);
  in.append_doubles(whole.xhatdot);
  const auto count = std::size_t(in.value<std::uint64_t>());
  for (std::size_t b = 0; b < count; ++b) {
    RolloutOutcome o;
    impl::for_each_outcome_field([&](const auto& field) { in.field(o.*field.member); });
    whole.outcomes.push_back(std::move(o));
  }
}

std::string rank_checkpoint_path(const std::string& path, int rank, int size) {
  return size > 1 ? path + ".rank" + std::to_string(rank) : path;
}

}  // namespace mpmrom
