#include "StepHistory.h"
#include "StiffModes.h"
#include <algorithm>
#include <cstdint>
#include <istream>
#include <ostream>
#include <utility>

using namespace FlavorPlugin;
using OpenMM::Vec3;
using std::vector;

namespace {

template <class T> bool readValue(std::istream& stream, T& value) {
    stream.read(reinterpret_cast<char*>(&value), sizeof(T));
    return stream.gcount() == (std::streamsize)sizeof(T);
}

// A per-particle history vector as its count of nonzero entries, then (index, x, y, z) for each.
void writeVector(std::ostream& stream, const vector<Vec3>& values) {
    std::uint32_t count = 0;
    for (const Vec3& value : values)
        count += (value != Vec3());
    stream.write((const char*)&count, sizeof(count));
    for (size_t i = 0; i < values.size(); ++i) {
        if (values[i] == Vec3())
            continue;
        const std::int32_t particle = (std::int32_t)i;
        stream.write((const char*)&particle, sizeof(particle));
        for (int d = 0; d < 3; ++d) {
            const double component = values[i][d];
            stream.write((const char*)&component, sizeof(component));
        }
    }
}

bool readVector(std::istream& stream, int numParticles, vector<std::pair<int, Vec3>>& entries) {
    std::uint32_t count = 0;
    if (!readValue(stream, count) || count > (std::uint32_t)numParticles)
        return false;
    entries.resize(count);
    for (auto& entry : entries) {
        std::int32_t particle = -1;
        if (!readValue(stream, particle) || particle < 0 || particle >= numParticles)
            return false;
        entry.first = particle;
        for (int d = 0; d < 3; ++d)
            if (!readValue(stream, entry.second[d]))
                return false;
    }
    return true;
}

} // namespace

StepHistory::StepHistory(int numParticles)
    : forceDifferences(numParticles), constraintProcessing(numParticles), openingForces(numParticles) {}

void StepHistory::forget() {
    // OpenMM announces the positions and velocities of a checkpoint after the integrator has read its part.
    if (loaded)
        return;
    std::fill(forceDifferences.begin(), forceDifferences.end(), Vec3());
    std::fill(constraintProcessing.begin(), constraintProcessing.end(), Vec3());
}

void StepHistory::keepOnly(const StiffModes* modes) {
    for (size_t i = 0; i < forceDifferences.size(); ++i)
        if (!modes || !modes->isStiffParticle((int)i))
            forceDifferences[i] = constraintProcessing[i] = Vec3();
}

void StepHistory::write(std::ostream& stream) const {
    writeVector(stream, forceDifferences);
    writeVector(stream, constraintProcessing);
}

bool StepHistory::read(std::istream& stream, Stored& stored, bool olderFormat) const {
    const int numParticles = (int)forceDifferences.size();
    if (olderFormat) {
        vector<std::pair<int, Vec3>> shares;
        return readVector(stream, numParticles, shares) && readVector(stream, numParticles, stored.differences);
    }
    return readVector(stream, numParticles, stored.differences) && readVector(stream, numParticles, stored.processing);
}

void StepHistory::load(const Stored& stored) {
    loaded = false;
    forget();
    loaded = true;
    for (const auto& entry : stored.differences)
        forceDifferences[entry.first] = entry.second;
    for (const auto& entry : stored.processing)
        constraintProcessing[entry.first] = entry.second;
}
