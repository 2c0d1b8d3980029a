#ifndef OPENMM_FLAVORS_MIXED4_STAGING_H_
#define OPENMM_FLAVORS_MIXED4_STAGING_H_

#include "openmm/Vec3.h"
#include "openmm/common/ComputeVectorTypes.h"
#include <vector>

namespace FlavorPlugin {

/**
 * Host staging for a per-particle device array of `mixed4` in the System's order (force slots, force differences):
 * double or float as the Context keeps `mixed`, converted from and to Vec3.  Sized once; the fourth
 * component goes to the device as zero.
 */
class Mixed4Staging {
public:
    Mixed4Staging(bool doubles, int size) : doubles(doubles) {
        if (doubles)
            doubleValues.resize(size);
        else
            floatValues.resize(size);
    }
    /** The host buffer for ArrayInterface::download() and upload(). */
    void* data() { return doubles ? (void*)doubleValues.data() : (void*)floatValues.data(); }
    void toVec3(std::vector<OpenMM::Vec3>& values) const {
        for (size_t i = 0; i < values.size(); ++i)
            values[i] = doubles ? OpenMM::Vec3(doubleValues[i].x, doubleValues[i].y, doubleValues[i].z)
                                : OpenMM::Vec3(floatValues[i].x, floatValues[i].y, floatValues[i].z);
    }
    void fromVec3(const std::vector<OpenMM::Vec3>& values) {
        for (size_t i = 0; i < values.size(); ++i)
            if (doubles)
                doubleValues[i] = OpenMM::mm_double4(values[i][0], values[i][1], values[i][2], 0.0);
            else
                floatValues[i] = OpenMM::mm_float4((float)values[i][0], (float)values[i][1], (float)values[i][2], 0.0f);
    }

private:
    bool doubles;
    std::vector<OpenMM::mm_double4> doubleValues;
    std::vector<OpenMM::mm_float4> floatValues;
};

} // namespace FlavorPlugin

#endif
