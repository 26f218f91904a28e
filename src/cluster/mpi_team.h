// MPI across processes and machines (optional: built when CMake finds MPI, CBDPT_HAVE_MPI).
// Under `mpirun -n N cbdpt render ...` (or Slurm's srun) the ranks render every N-th of the
// estimates left, agree once per estimate on stopping and checkpoints by rank 0's clock, and
// reduce their exact sums to rank 0, which writes every output (docs/scale-out.md).
#pragma once

#include "integrators/render.h"

#include <memory>

namespace cb {

// True when this process was started by an MPI launcher (mpirun, mpiexec, srun with PMI/PMIx).
bool launchedByMpi();

// The team of this process's MPI job: initialises MPI (finalised when the team is destroyed).
// nullptr when cbdpt was built without MPI or not started by an MPI launcher. Where several
// ranks share a machine and POCL_MAX_PTHREAD_COUNT is not set, it is set to the machine's cores
// divided by its ranks, so that each rank's PoCL device gets its share of the cores.
std::unique_ptr<RenderTeam> joinMpiTeam();

// Whether this build has MPI support.
bool mpiAvailable();

// Ends every rank of the job (MPI_Abort): a rank that fails alone would leave the others
// waiting in a collective call. Does nothing without MPI.
void abortMpiJob(int code);

} // namespace cb
