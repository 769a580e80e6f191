#pragma once
// DDS domain ids for tests, benchmarks and scripts that run side by side on one machine. A domain
// is a namespace shared by every process of the host: two tests in one domain with the same space
// or robot names would answer each other's calls. Each id is reserved by an exclusive lock on
// /tmp/urs-dds-domains/<id>, held as long as the object lives and released by the kernel when the
// process dies, whatever kills it; deploy/lab.sh takes the same locks with flock(1).

#include <cstdint>
#include <vector>

namespace urs::test {

class DdsDomains {
 public:
  // Reserves `count` distinct ids in 10..230 (Fast DDS's highest usable domain is 232), starting
  // the search at a place derived from the pid. Throws std::runtime_error if none is free.
  explicit DdsDomains(unsigned count = 1);
  ~DdsDomains();
  DdsDomains(const DdsDomains&) = delete;
  DdsDomains& operator=(const DdsDomains&) = delete;

  uint32_t operator[](unsigned i) const { return ids_.at(i); }

 private:
  std::vector<uint32_t> ids_;
  std::vector<int> fds_;
};

}  // namespace urs::test
