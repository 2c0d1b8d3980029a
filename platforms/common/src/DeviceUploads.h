#ifndef OPENMM_FLAVORS_DEVICE_UPLOADS_H_
#define OPENMM_FLAVORS_DEVICE_UPLOADS_H_

#include "MixedArguments.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include <string>
#include <vector>

namespace FlavorPlugin {

/** Uploads values into a mixed-precision array, created with at least one element. */
inline void uploadMixed(OpenMM::ComputeContext& cc, OpenMM::ComputeArray& array, std::vector<double> values,
                        const std::string& name) {
    const bool doubles = mixedIsDouble(cc);
    if (values.empty())
        values.push_back(0.0);
    if (!array.isInitialized() || (size_t)array.getSize() != values.size()) {
        if (array.isInitialized())
            array.resize((int)values.size());
        else
            array.initialize(cc, (int)values.size(), doubles ? sizeof(double) : sizeof(float), name);
    }
    array.upload(values, true);
}

/** Uploads ints into an array, created with at least one element. */
inline void uploadInts(OpenMM::ComputeContext& cc, OpenMM::ComputeArray& array, std::vector<int> values,
                       const std::string& name) {
    if (values.empty())
        values.push_back(0);
    if (!array.isInitialized())
        array.initialize<int>(cc, (int)values.size(), name);
    else if ((size_t)array.getSize() != values.size())
        array.resize((int)values.size());
    array.upload(values);
}

/** A per-particle array of mixed4 on the device (system order), zero. */
inline void initializeMixed4(OpenMM::ComputeContext& cc, OpenMM::ComputeArray& array, int size,
                             const std::string& name) {
    const bool doubles = mixedIsDouble(cc);
    array.initialize(cc, size, doubles ? 4 * sizeof(double) : 4 * sizeof(float), name);
    cc.clearBuffer(array);
}

} // namespace FlavorPlugin

#endif
