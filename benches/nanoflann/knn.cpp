// k-nearest-neighbour queries with nanoflann, the C++ kd-tree the seed
// report used, on the points and queries `caustix bench photons --dump`
// wrote: the same work kiddo does in caustix, for a like-for-like rate.
// Built and run by scripts/bench-nanoflann.sh.
#include <nanoflann.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <thread>
#include <vector>

struct Cloud {
    std::vector<float> xyz;  // x, y, z per point
    size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(size_t i, size_t dim) const { return xyz[3 * i + dim]; }
    template <class Box> bool kdtree_get_bbox(Box&) const { return false; }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, uint32_t>;

static double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Answers queries [begin, end); returns the sum of squared distances found.
static double answer(const Tree& tree, const std::vector<float>& queries, size_t begin, size_t end, uint32_t k) {
    std::vector<uint32_t> index(k);
    std::vector<float> distance(k);
    double sum = 0;
    for (size_t q = begin; q < end; ++q) {
        size_t found = tree.knnSearch(&queries[3 * q], k, index.data(), distance.data());
        for (size_t i = 0; i < found; ++i) sum += distance[i];
    }
    return sum;
}

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s POINTS.bin (from caustix bench photons --dump)\n", argv[0]);
        return 2;
    }
    std::ifstream in(argv[1], std::ios::binary);
    uint64_t n = 0, q = 0;
    uint32_t k = 0;
    Cloud cloud;
    std::vector<float> queries;
    in.read(reinterpret_cast<char*>(&n), 8);
    cloud.xyz.resize(3 * n);
    in.read(reinterpret_cast<char*>(cloud.xyz.data()), 12 * n);
    in.read(reinterpret_cast<char*>(&q), 8);
    queries.resize(3 * q);
    in.read(reinterpret_cast<char*>(queries.data()), 12 * q);
    in.read(reinterpret_cast<char*>(&k), 4);
    if (!in) {
        std::fprintf(stderr, "%s: truncated or not a caustix dump\n", argv[1]);
        return 1;
    }

    auto start = std::chrono::steady_clock::now();
    Tree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    double build = seconds_since(start);

    start = std::chrono::steady_clock::now();
    double sum = answer(tree, queries, 0, q, k);
    double one = seconds_since(start);

    unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> workers;
    std::vector<double> sums(threads);
    start = std::chrono::steady_clock::now();
    for (unsigned t = 0; t < threads; ++t) {
        workers.emplace_back([&, t] { sums[t] = answer(tree, queries, q * t / threads, q * (t + 1) / threads, k); });
    }
    for (auto& w : workers) w.join();
    double all = seconds_since(start);

    std::printf("nanoflann %d.%d.%d: %llu points, build %.2f s; %llu queries, k = %u: %.3f M/s on 1 thread, "
                "%.3f M/s on %u threads; sum of squared distances %.6e\n",
                NANOFLANN_VERSION >> 8, (NANOFLANN_VERSION >> 4) & 0xf, NANOFLANN_VERSION & 0xf,
                (unsigned long long)n, build, (unsigned long long)q, k, q / one / 1e6, q / all / 1e6, threads, sum);
    return 0;
}
