// Owen-scrambled Sobol sampler: the non-inline parts (the hot path lives in the header).
#include "sampling/sequence.h"

#include <sstream>

namespace tessera::sampling {

alignas(64) const uint32_t kSobolMatrices[kSobolMatrixDimensions][32] = {
#include "sampling/sobol_matrices.inc"
};

std::string SobolSampler::describe() const {
    std::ostringstream os;
    os << "SobolSampler(owen-scrambled "
       << pattern_name(pattern_) << ", seed=" << seed_ << ", pixel=(" << px_ << ", "
       << py_ << "), index=" << index_ << ", dimension=" << dim_ << ")";
    return os.str();
}

}  // namespace tessera::sampling
