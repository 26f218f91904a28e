#include "cluster/mpi_team.h"

#include <cstdlib>
#include <stdexcept>
#include <string>
#include <thread>

#ifdef CBDPT_HAVE_MPI
#include <mpi.h>

#include <chrono>
#endif

namespace cb {

bool launchedByMpi() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(name)) return true;
    return false;
}

#ifndef CBDPT_HAVE_MPI

bool mpiAvailable() {
    return false;
}
void abortMpiJob(int) {}
std::unique_ptr<RenderTeam> joinMpiTeam() {
    return nullptr;
}
#else

namespace {

void check(int status, const char* call) {
    if (status != MPI_SUCCESS)
        throw std::runtime_error(std::string("MPI call ") + call + " failed with status " +
                                 std::to_string(status));
}

// Element-wise exact sum of fixed-point numbers of `Words` words (carries across words).
template <int Words> void addFixed(void* in, void* inout, int* count, MPI_Datatype*) {
    auto* a = static_cast<const FixedPoint<Words>*>(in);
    auto* b = static_cast<FixedPoint<Words>*>(inout);
    for (int i = 0; i < *count; ++i)
        b[i].add(a[i]);
}

class MpiTeam final : public RenderTeam {
  public:
    MpiTeam() {
        check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
        check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "MPI_Comm_size");
        check(MPI_Type_contiguous(int(SampleSum{}.word.size()), MPI_UINT64_T, &sampleType_),
              "MPI_Type_contiguous");
        check(MPI_Type_commit(&sampleType_), "MPI_Type_commit");
        check(MPI_Type_contiguous(int(SquareSum{}.word.size()), MPI_UINT64_T, &squareType_),
              "MPI_Type_contiguous");
        check(MPI_Type_commit(&squareType_), "MPI_Type_commit");
        // Integer addition is commutative and associative, so MPI may reduce in any order.
        check(MPI_Op_create(&addFixed<3>, 1, &sampleOp_), "MPI_Op_create");
        check(MPI_Op_create(&addFixed<4>, 1, &squareOp_), "MPI_Op_create");
    }
    ~MpiTeam() override {
        MPI_Op_free(&sampleOp_);
        MPI_Op_free(&squareOp_);
        MPI_Type_free(&sampleType_);
        MPI_Type_free(&squareType_);
        MPI_Finalize();
    }
    int rank() const override { return rank_; }
    int size() const override { return size_; }
    void sumAll(std::vector<double>& values) override {
        check(MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_SUM,
                            MPI_COMM_WORLD),
              "MPI_Allreduce");
    }
    EstimateSet shareFromRoot(const EstimateSet& indices) override {
        std::vector<std::uint64_t> flat = flatten(indices);
        std::uint64_t n = flat.size();
        check(MPI_Bcast(&n, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD), "MPI_Bcast");
        flat.resize(n);
        check(MPI_Bcast(flat.data(), int(n), MPI_UINT64_T, 0, MPI_COMM_WORLD), "MPI_Bcast");
        return unflatten(flat);
    }
    const EstimateAccumulator* gather(const EstimateAccumulator& local) override {
        const auto start = std::chrono::steady_clock::now();
        // The render's last checkpoint has reduced the sums that finishing reduces again: when
        // no rank's accumulator changed since the last reduction, rank 0's total still holds.
        const Fingerprint now{&local, local.estimates(), local.droppedSamples()};
        int changed = reduced_ && now == last_ ? 0 : 1;
        check(MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD),
              "MPI_Allreduce");
        if (!changed) return rank_ == 0 ? &total_ : nullptr;
        const EstimateAccumulator* total = reduce(local);
        reduced_ = true;
        last_ = now;
        reductionSeconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        ++reductions_;
        return total;
    }
    double reductionSeconds() const override { return reductionSeconds_; }
    long reductions() const override { return reductions_; }

  private:
    const EstimateAccumulator* reduce(const EstimateAccumulator& local) {
        const bool root = rank_ == 0;
        if (root && (total_.width() != local.width() || total_.height() != local.height() ||
                     total_.tracksHalves() != local.tracksHalves())) {
            total_ = EstimateAccumulator(local.width(), local.height());
            if (local.tracksHalves()) total_.trackHalves();
        }
        // The accumulators' parts (halves apart when tracked), each summed over the ranks:
        // every rank runs the same command, so all track halves or none do.
        const int count = int(local.values());
        for (int part = 0; part < (local.tracksHalves() ? 2 : 1); ++part) {
            check(MPI_Reduce(local.partSums(part).data(),
                             root ? total_.partSums(part).data() : nullptr, count, sampleType_,
                             sampleOp_, 0, MPI_COMM_WORLD),
                  "MPI_Reduce");
            check(MPI_Reduce(local.partSquares(part).data(),
                             root ? total_.partSquares(part).data() : nullptr, count, squareType_,
                             squareOp_, 0, MPI_COMM_WORLD),
                  "MPI_Reduce");
        }
        long dropped = local.droppedSamples(), totalDropped = 0;
        check(MPI_Reduce(&dropped, &totalDropped, 1, MPI_LONG, MPI_SUM, 0, MPI_COMM_WORLD),
              "MPI_Reduce");
        // The estimate sets: each rank's ranges, gathered and united on rank 0.
        const std::vector<std::uint64_t> mine = flatten(local.indices());
        int myCount = int(mine.size());
        std::vector<int> counts(root ? size_t(size_) : 0), offsets;
        check(MPI_Gather(&myCount, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD),
              "MPI_Gather");
        std::vector<std::uint64_t> all;
        if (root) {
            int sum = 0;
            for (int c : counts) {
                offsets.push_back(sum);
                sum += c;
            }
            all.resize(size_t(sum));
        }
        check(MPI_Gatherv(mine.data(), myCount, MPI_UINT64_T, all.data(), counts.data(),
                          offsets.data(), MPI_UINT64_T, 0, MPI_COMM_WORLD),
              "MPI_Gatherv");
        if (!root) return nullptr;
        EstimateSet united;
        for (int r = 0; r < size_; ++r)
            united.unite(unflatten(
                std::vector<std::uint64_t>(all.begin() + offsets[size_t(r)],
                                           all.begin() + offsets[size_t(r)] + counts[size_t(r)])));
        total_.setIndices(std::move(united));
        total_.setDroppedSamples(totalDropped);
        return &total_;
    }

    static std::vector<std::uint64_t> flatten(const EstimateSet& s) {
        std::vector<std::uint64_t> flat;
        for (const auto& [b, e] : s.ranges()) {
            flat.push_back(b);
            flat.push_back(e);
        }
        return flat;
    }
    static EstimateSet unflatten(const std::vector<std::uint64_t>& flat) {
        std::vector<EstimateSet::Range> ranges;
        for (size_t i = 0; i + 1 < flat.size(); i += 2)
            ranges.emplace_back(flat[i], flat[i + 1]);
        return EstimateSet::fromRanges(std::move(ranges));
    }
    // What identifies a local accumulator's content: estimates are only ever added to it.
    struct Fingerprint {
        const EstimateAccumulator* accumulator = nullptr;
        long estimates = 0, dropped = 0;
        bool operator==(const Fingerprint&) const = default;
    };
    bool reduced_ = false;
    Fingerprint last_;
    int rank_ = 0, size_ = 1;
    MPI_Datatype sampleType_{}, squareType_{};
    MPI_Op sampleOp_{}, squareOp_{};
    EstimateAccumulator total_{0, 0};
    double reductionSeconds_ = 0.0;
    long reductions_ = 0;
};

} // namespace

bool mpiAvailable() {
    return true;
}
void abortMpiJob(int code) {
    MPI_Abort(MPI_COMM_WORLD, code);
}

std::unique_ptr<RenderTeam> joinMpiTeam() {
    if (!launchedByMpi()) return nullptr;
    check(MPI_Init(nullptr, nullptr), "MPI_Init");
    // Ranks on one machine share its cores: PoCL's thread count per rank, unless set.
    MPI_Comm local;
    check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &local),
          "MPI_Comm_split_type");
    int localRanks = 1;
    MPI_Comm_size(local, &localRanks);
    MPI_Comm_free(&local);
    if (!std::getenv("POCL_MAX_PTHREAD_COUNT") && localRanks > 1) {
        const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
        const unsigned share = std::max(1u, cores / unsigned(localRanks));
        setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(share).c_str(), 1);
    }
    return std::make_unique<MpiTeam>();
}

#endif

} // namespace cb
