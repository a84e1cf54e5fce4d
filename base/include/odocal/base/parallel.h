// The one worker pool: independent jobs (a video to decode, a run to render)
// spread over the cores, each job taken once, in index order.
#ifndef ODOCAL_BASE_PARALLEL_H_
#define ODOCAL_BASE_PARALLEL_H_

#include <cstddef>
#include <functional>

namespace odocal {

// Calls job(i) once for every i in [0, n), on at most `threads` workers
// (0: one per core; never more than n), and returns when all are done. Jobs
// run concurrently: what they share must be atomic or locked. Jobs must not
// throw.
void ParallelFor(std::size_t n, unsigned threads, const std::function<void(std::size_t)>& job);

}  // namespace odocal

#endif  // ODOCAL_BASE_PARALLEL_H_
