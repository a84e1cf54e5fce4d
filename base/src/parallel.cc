#include "odocal/base/parallel.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace odocal {

void ParallelFor(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& job) {
  const unsigned cores = threads > 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t workers = std::max<std::size_t>(1, std::min<std::size_t>(n, cores));
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> pool;
  pool.reserve(workers);
  for (std::size_t w = 0; w < workers; ++w) {
    pool.emplace_back([&]() {
      for (std::size_t i = next++; i < n; i = next++) job(i);
    });
  }
  for (std::thread& t : pool) t.join();
}

}  // namespace odocal
