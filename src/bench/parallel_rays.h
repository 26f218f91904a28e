// Runs f(begin, end) over [0, n) in chunks handed out from a shared counter, on `threads`
// std::threads: how cbdpt-bench spreads rays for the Embree baseline and the host traversal,
// as PoCL spreads work-groups over its threads. With one fixed range per thread, the thread
// whose half of the image held more of the mesh finished last and the other's idle wait counted
// in the wall time (the Embree wall ratio of primary rays read 0.1-0.15 above the CPU ratio).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <thread>
#include <vector>

namespace cb::bench {

template <typename F> void parallelRayChunks(std::size_t n, int threads, F f) {
    constexpr std::size_t kChunk = 1024;
    std::atomic<std::size_t> next{0};
    auto worker = [&] {
        for (std::size_t begin = next.fetch_add(kChunk); begin < n; begin = next.fetch_add(kChunk))
            f(begin, std::min(n, begin + kChunk));
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t)
        pool.emplace_back(worker);
    for (auto& th : pool)
        th.join();
}

} // namespace cb::bench
