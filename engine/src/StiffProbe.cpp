#include "StiffProbe.h"
#include "internal/ParameterChecks.h"
#include "internal/StiffGroupChecks.h"
#include "internal/UnionFind.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/NonbondedForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/State.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/internal/ForceImpl.h"
#include "openmm/reference/ReferencePlatform.h"
#include "openmm/serialization/XmlSerializer.h"
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <random>
#include <utility>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

const double ProbeStep = 1e-3; // nm; exact for a quadratic potential, any step would do
// nm; large enough that a nonlinear force far from its minimum (a bond of rest length 0.1 nm stretched to 3 nm)
// still shows its curvature, harmless for a quadratic one, which is linear at any displacement.
const double VerificationDisplacement = 0.05;
const double LinearityTolerance = 1e-5; // relative; well above double-precision rounding of the probes

bool inGroups(int group, int groups) {
    return (groups & (1 << group)) != 0;
}

bool inGroups(const ForceImpl* impl, int groups) {
    return inGroups(impl->getOwner().getForceGroup(), groups);
}

/** Labels each particle with a group of particles linked by bonded stiff forces. */
vector<int> bondedGroups(ContextImpl& context, int stiffGroups) {
    const int n = context.getSystem().getNumParticles();
    vector<int> parent(n);
    std::iota(parent.begin(), parent.end(), 0);
    for (ForceImpl* impl : context.getForceImpls())
        if (inGroups(impl, stiffGroups))
            for (const std::pair<int, int>& bond : impl->getBondedParticles())
                parent[findRoot(parent, bond.first)] = findRoot(parent, bond.second);
    vector<int> label(n);
    for (int i = 0; i < n; ++i)
        label[i] = findRoot(parent, i);
    return label;
}

/**
 * The stiff forces of a Context on a platform other than Reference and CPU, evaluated in double precision: a copy of
 * its System that keeps only the forces of the stiff groups, on the Reference platform, with the Context's box
 * vectors and parameters.  OpenCL's single and mixed precision round positions to single precision, 1e-7 to 5e-7 nm
 * a few nm from the origin, which a probe step of 1e-3 nm cannot tell from a nonlinear force (1.5e-5 to 4e-5 relative
 * on FPU chains and Drude waters in a box).  The copy is of the System as it is at the measurement: a change of a
 * force's parameters reaches it as it reaches the Context, through updateParametersInContext(), which measures again.
 */
class ReferenceStiffForces {
public:
    /** Throws an OpenMMException if the System cannot be copied (a force without a serialization proxy). */
    ReferenceStiffForces(ContextImpl& context, int groups) : groups(groups), integrator(0.001) {
        system.reset(XmlSerializer::clone<System>(context.getSystem()));
        for (int f = system->getNumForces() - 1; f >= 0; --f) {
            const Force& force = system->getForce(f);
            const NonbondedForce* nonbonded = dynamic_cast<const NonbondedForce*>(&force);
            const bool reciprocalStiff = nonbonded != nullptr && nonbonded->getReciprocalSpaceForceGroup() >= 0 &&
                                         inGroups(nonbonded->getReciprocalSpaceForceGroup(), groups);
            if (!inGroups(force.getForceGroup(), groups) && !reciprocalStiff)
                system->removeForce(f);
        }
        copy = std::make_unique<Context>(*system, integrator, Platform::getPlatformByName("Reference"));
        Vec3 a, b, c;
        context.getPeriodicBoxVectors(a, b, c);
        copy->setPeriodicBoxVectors(a, b, c);
        const std::map<string, double> own = copy->getParameters();
        for (const auto& parameter : context.getParameters())
            if (own.count(parameter.first) != 0)
                copy->setParameter(parameter.first, parameter.second);
    }
    vector<Vec3> forces(const vector<Vec3>& q) {
        copy->setPositions(q);
        copy->computeVirtualSites();
        return copy->getState(State::Forces, false, groups).getForces();
    }

private:
    int groups;
    std::unique_ptr<System> system;
    VerletIntegrator integrator;
    std::unique_ptr<Context> copy;
};

/**
 * Evaluates the stiff forces at displaced positions and puts the Context's positions back afterwards.  On Reference
 * and CPU it writes positions and reads forces in ReferencePlatform::PlatformData; on every other platform (OpenCL)
 * it evaluates them on a double-precision copy (ReferenceStiffForces), or, where the System cannot be copied, goes
 * through ContextImpl's getPositions/setPositions/getForces.
 */
class ForceProbe {
public:
    ForceProbe(ContextImpl& context, int groups)
        : context(context), groups(groups), data(referenceData(context)), hasVirtualSites(false) {
        if (data != nullptr)
            original = *data->positions;
        else {
            context.getPositions(original);
            try {
                reference = std::make_unique<ReferenceStiffForces>(context, groups);
            } catch (const OpenMMException&) {
                // Probed through the Context itself, in its own precision.
            }
        }
        for (int i = 0; i < context.getSystem().getNumParticles(); ++i)
            hasVirtualSites = hasVirtualSites || context.getSystem().isVirtualSite(i);
        // OpenMM 7.7's Reference NonbondedForce kernel rebuilds its neighbour list on every force evaluation, even
        // of groups it is not in (50 ms for 1,500 atoms with PME): on Reference, whose force evaluation is only
        // "zero the forces, let each ForceImpl add its own" (plus virtual-site forces, and a NonbondedForce may
        // put its reciprocal space in another group), the probe asks only the ForceImpls of the stiff groups.
        bool direct = context.getPlatform().getName() == "Reference" && !hasVirtualSites;
        for (ForceImpl* impl : context.getForceImpls()) {
            const NonbondedForce* nonbonded = dynamic_cast<const NonbondedForce*>(&impl->getOwner());
            if (nonbonded != nullptr && nonbonded->getReciprocalSpaceForceGroup() >= 0)
                direct = false;
            if (inGroups(impl, groups))
                stiffImpls.push_back(impl);
        }
        if (!direct)
            stiffImpls.clear();
    }
    ~ForceProbe() {
        if (reference != nullptr)
            return; // the Context's positions were never moved
        setPositions(original);
        if (hasVirtualSites)
            context.computeVirtualSites();
    }
    /** The stiff forces at positions q. */
    vector<Vec3> forces(const vector<Vec3>& q) {
        if (reference != nullptr)
            return reference->forces(q);
        setPositions(q);
        if (hasVirtualSites)
            context.computeVirtualSites();
        // The first evaluation goes through the Context, which checks that positions have been set.
        if (stiffImpls.empty() || !evaluatedOnce)
            context.calcForcesAndEnergy(true, false, groups);
        else {
            std::fill(data->forces->begin(), data->forces->end(), Vec3());
            for (ForceImpl* impl : stiffImpls)
                impl->calcForcesAndEnergy(context, true, false, groups);
        }
        evaluatedOnce = true;
        if (data != nullptr)
            return *data->forces;
        vector<Vec3> result;
        context.getForces(result);
        return result;
    }
    const vector<Vec3>& positions() const { return original; }

private:
    /** The particle data of Reference and CPU Contexts; null on other platforms. */
    static ReferencePlatform::PlatformData* referenceData(ContextImpl& context) {
        const std::string& name = context.getPlatform().getName();
        if (name != "Reference" && name != "CPU")
            return nullptr;
        return reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
    }
    void setPositions(const vector<Vec3>& q) {
        if (data != nullptr)
            *data->positions = q;
        else
            context.setPositions(q);
    }
    ContextImpl& context;
    int groups;
    ReferencePlatform::PlatformData* data;
    vector<Vec3> original;
    bool hasVirtualSites;
    // On Reference, the ForceImpls of the stiff groups, evaluated directly; empty where the Context evaluates.
    vector<ForceImpl*> stiffImpls;
    // On other platforms, the double-precision copy of the stiff forces (null where the System cannot be copied).
    std::unique_ptr<ReferenceStiffForces> reference;
    bool evaluatedOnce = false;
};

typedef std::map<std::pair<int, int>, StiffnessBlock> BlockMap;

/**
 * Central differences, probing the c-th particle of every group at once.  Returns false if a force appeared on a
 * particle whose group has no c-th member (the groups missed a coupling).
 */
bool probeByGroups(ForceProbe& probe, const vector<int>& label, const vector<double>& masses, BlockMap& blocks) {
    const int n = (int)masses.size();
    std::map<int, vector<int>> members;
    for (int i = 0; i < n; ++i)
        if (masses[i] != 0.0)
            members[label[i]].push_back(i);
    vector<int> indexInGroup(n, -1);
    size_t largest = 0;
    for (auto& m : members) {
        for (size_t k = 0; k < m.second.size(); ++k)
            indexInGroup[m.second[k]] = (int)k;
        largest = std::max(largest, m.second.size());
    }
    for (size_t c = 0; c < largest; ++c)
        for (int d = 0; d < 3; ++d) {
            vector<Vec3> plus = probe.positions(), minus = probe.positions();
            for (int i = 0; i < n; ++i)
                if (indexInGroup[i] == (int)c) {
                    plus[i][d] += ProbeStep;
                    minus[i][d] -= ProbeStep;
                }
            vector<Vec3> fPlus = probe.forces(plus), fMinus = probe.forces(minus);
            for (int j = 0; j < n; ++j) {
                Vec3 change = (fPlus[j] - fMinus[j]) / (2 * ProbeStep);
                if (change == Vec3() || masses[j] == 0.0)
                    continue;
                const vector<int>& group = members[label[j]];
                if (c >= group.size())
                    return false;
                const int i = group[c];
                StiffnessBlock& block = blocks[{j, i}];
                block.i = j;
                block.j = i;
                for (int r = 0; r < 3; ++r)
                    block.k[r][d] = -change[r];
            }
        }
    return true;
}

double maxAbs(const BlockMap& blocks) {
    double m = 0;
    for (const auto& b : blocks)
        for (int r = 0; r < 3; ++r)
            for (int s = 0; s < 3; ++s)
                m = std::max(m, std::abs(b.second.k[r][s]));
    return m;
}

/**
 * Symmetrizes K into blocks with i <= j.  Returns false, naming a pair of particles, if K is not symmetric.
 */
bool symmetricBlocks(const BlockMap& blocks, vector<StiffnessBlock>& result, std::pair<int, int>& asymmetric,
                     double& asymmetry) {
    const double scale = maxAbs(blocks);
    result.clear();
    for (const auto& entry : blocks) {
        const StiffnessBlock& b = entry.second;
        auto transposed = blocks.find({b.j, b.i});
        if (b.i > b.j && transposed != blocks.end())
            continue;
        StiffnessBlock s = b;
        if (b.i > b.j)
            std::swap(s.i, s.j);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                double other = (transposed == blocks.end() ? 0.0 : transposed->second.k[c][r]);
                if (std::abs(b.k[r][c] - other) > LinearityTolerance * scale) {
                    asymmetric = {b.i, b.j};
                    asymmetry = std::abs(b.k[r][c] - other) / scale;
                    return false;
                }
                s.k[r][c] = 0.5 * (b.k[r][c] + other);
            }
        double largest = 0;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                largest = std::max(largest, std::abs(s.k[r][c]));
        if (largest > 1e-12 * scale)
            result.push_back(s);
    }
    return true;
}

vector<Vec3> multiply(const vector<StiffnessBlock>& blocks, const vector<Vec3>& q) {
    vector<Vec3> result(q.size());
    for (const StiffnessBlock& b : blocks) {
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                result[b.i][r] += b.k[r][c] * q[b.j][c];
                if (b.i != b.j)
                    result[b.j][c] += b.k[r][c] * q[b.i][r];
            }
    }
    return result;
}

/**
 * A seeded random displacement of every particle with mass (massless particles are fixed: they never move, and
 * the forces on them do not matter).
 */
vector<Vec3> randomDisplacement(const vector<double>& masses, std::uint64_t seed) {
    std::mt19937_64 generator(seed);
    std::uniform_real_distribution<double> uniform(-VerificationDisplacement, VerificationDisplacement);
    vector<Vec3> displacement(masses.size());
    for (size_t i = 0; i < masses.size(); ++i)
        if (masses[i] != 0.0)
            displacement[i] = Vec3(uniform(generator), uniform(generator), uniform(generator));
    return displacement;
}

vector<Vec3> displaced(const vector<Vec3>& q, const vector<Vec3>& displacement, double factor) {
    vector<Vec3> result = q;
    for (size_t i = 0; i < q.size(); ++i)
        result[i] += displacement[i] * factor;
    return result;
}

/**
 * Tests linearity before any probing, with three force evaluations besides F(q): along a random displacement D of
 * every particle with mass, the second difference F(q+D) + F(q-D) - 2F(q) and the third difference
 * F(q+2D) - 3F(q+D) + 3F(q) - F(q-D) of a force linear in q vanish.  Returns the larger of the two, relative to the
 * first difference F(q+D) - F(q-D) (the largest values over the particles with mass).
 */
double quickLinearityDeviation(ForceProbe& probe, const vector<double>& masses, const vector<Vec3>& f0) {
    const vector<Vec3> displacement = randomDisplacement(masses, 19700101);
    const vector<Vec3>& q = probe.positions();
    const vector<Vec3> fPlus = probe.forces(displaced(q, displacement, 1.0));
    const vector<Vec3> fMinus = probe.forces(displaced(q, displacement, -1.0));
    const vector<Vec3> fPlus2 = probe.forces(displaced(q, displacement, 2.0));
    double deviation = 0, scale = 0;
    for (size_t i = 0; i < masses.size(); ++i) {
        if (masses[i] == 0.0)
            continue;
        const Vec3 first = fPlus[i] - fMinus[i];
        const Vec3 second = fPlus[i] + fMinus[i] - f0[i] * 2.0;
        const Vec3 third = fPlus2[i] - fPlus[i] * 3.0 + f0[i] * 3.0 - fMinus[i];
        scale = std::max(scale, std::sqrt(first.dot(first)));
        deviation = std::max(deviation, std::max(std::sqrt(second.dot(second)), std::sqrt(third.dot(third))));
    }
    if (scale == 0.0)
        return deviation == 0.0 ? 0.0 : INFINITY;
    return deviation / scale;
}

/**
 * max |F(q+D) - F(q) + K D| / max |K D| at a seeded random displacement D, over the particles with mass.
 */
double linearityDeviation(ForceProbe& probe, const vector<StiffnessBlock>& blocks, const vector<double>& masses,
                          const vector<Vec3>& f0) {
    const vector<Vec3> displacement = randomDisplacement(masses, 20100425);
    vector<Vec3> f1 = probe.forces(displaced(probe.positions(), displacement, 1.0)),
                 predicted = multiply(blocks, displacement);
    double deviation = 0, scale = 0;
    for (size_t i = 0; i < masses.size(); ++i) {
        if (masses[i] == 0.0)
            continue;
        Vec3 d = f1[i] - f0[i] + predicted[i];
        deviation = std::max(deviation, std::sqrt(d.dot(d)));
        scale = std::max(scale, std::sqrt(predicted[i].dot(predicted[i])));
    }
    if (scale == 0.0)
        return deviation == 0.0 ? 0.0 : INFINITY;
    return deviation / scale;
}

} // namespace

ProbedStiffness FlavorPlugin::probeStiffness(ContextImpl& context, int stiffGroups, const vector<double>& masses,
                                             const string& Owner, const string& alternative) {
    ForceProbe probe(context, stiffGroups);
    const vector<Vec3> f0 = probe.forces(probe.positions());
    const int n = (int)masses.size();
    const string quadraticExamples =
        string("The stiff potential must be quadratic (e.g. HarmonicBondForce with length 0, "
               "CustomBondForce \"k*r^2\", CustomExternalForce \"k*(x-x0)^2\"); ") +
        alternative;
    const double quickDeviation = quickLinearityDeviation(probe, masses, f0);
    if (!(quickDeviation <= LinearityTolerance))
        throw NotQuadraticException(
            Owner +
            ": the stiff force groups are not quadratic in the positions: along a random displacement of up "
            "to " +
            formatNumber(VerificationDisplacement) +
            " nm of every particle their forces are not linear: their second and third differences are " +
            formatNumber(quickDeviation) + " relative to the first difference (at most " +
            formatNumber(LinearityTolerance) + " allowed).  " + quadraticExamples);
    ProbedStiffness result;
    result.linearityDeviation = INFINITY;
    std::pair<int, int> asymmetric(-1, -1);
    double asymmetry = 0;
    for (bool everyParticleAlone : {false, true}) {
        vector<int> label(n, 0); // one group for all: one particle probed at a time
        if (!everyParticleAlone)
            label = bondedGroups(context, stiffGroups);
        BlockMap blocks;
        if (!probeByGroups(probe, label, masses, blocks))
            continue;
        if (!symmetricBlocks(blocks, result.blocks, asymmetric, asymmetry))
            continue;
        asymmetric = {-1, -1};
        result.linearityDeviation = linearityDeviation(probe, result.blocks, masses, f0);
        if (result.linearityDeviation <= LinearityTolerance)
            break;
    }
    if (asymmetric.first >= 0)
        throw NotQuadraticException(Owner +
                                    ": the stiff force groups are not quadratic in the positions: the measured "
                                    "stiffness between particles " +
                                    std::to_string(asymmetric.first) + " and " + std::to_string(asymmetric.second) +
                                    " is not symmetric (relative asymmetry " + formatNumber(asymmetry) + ", at most " +
                                    formatNumber(LinearityTolerance) + " allowed).  " + quadraticExamples);
    if (!(result.linearityDeviation <= LinearityTolerance))
        throw NotQuadraticException(
            Owner + ": the stiff force groups are not quadratic in the positions: at a random displacement of up to " +
            formatNumber(VerificationDisplacement) + " nm their forces differ from the linear prediction -K dq by " +
            formatNumber(result.linearityDeviation) + " (relative; at most " + formatNumber(LinearityTolerance) +
            " allowed).  " + quadraticExamples);
    vector<Vec3> kq = multiply(result.blocks, probe.positions());
    result.constantForce.resize(n);
    for (int i = 0; i < n; ++i)
        result.constantForce[i] = (masses[i] == 0.0 ? Vec3() : f0[i] + kq[i]);
    return result;
}

namespace {

/**
 * Whether two measurements describe the same potential up to the rounding of the probes.  Keeping the old modes
 * then keeps trajectories reproducible (a checkpoint restored elsewhere measures again): eigenvectors of degenerate
 * modes could otherwise rotate with the rounding, and the noise with them.  The rounding is that of double-precision
 * forces, about 1e-13 relative (Reference, CPU, and the Reference copy that other platforms are probed on); up to
 * 3e-10 with OpenCL's fixed-point forces where a System cannot be copied (measured at different positions of the same
 * quadratic potential), so SameRelative = 1e-8 separates it from any change of a force constant that matters.
 */
bool samePotential(const ProbedStiffness& a, const ProbedStiffness& b) {
    constexpr double SameRelative = 1e-8;
    if (a.blocks.size() != b.blocks.size() || a.constantForce.size() != b.constantForce.size())
        return false;
    double scale = 0;
    for (const StiffnessBlock& block : a.blocks)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                scale = std::max(scale, std::abs(block.k[r][c]));
    for (size_t n = 0; n < a.blocks.size(); ++n) {
        if (a.blocks[n].i != b.blocks[n].i || a.blocks[n].j != b.blocks[n].j)
            return false;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                if (std::abs(a.blocks[n].k[r][c] - b.blocks[n].k[r][c]) > SameRelative * scale)
                    return false;
    }
    // b = F(q) + K q is measured with the rounding of forces of size ~K |q|: compare on that scale (|q| ~ 1 nm).
    double forceScale = scale;
    for (const Vec3& f : a.constantForce)
        forceScale = std::max(forceScale, std::sqrt(f.dot(f)));
    for (size_t i = 0; i < a.constantForce.size(); ++i) {
        Vec3 d = a.constantForce[i] - b.constantForce[i];
        if (std::sqrt(d.dot(d)) > SameRelative * forceScale)
            return false;
    }
    return true;
}

} // namespace

StiffModesMeasurement::StiffModesMeasurement(const System& system, string owner, string alternative)
    : owner(std::move(owner)), alternative(std::move(alternative)) {
    masses.resize(system.getNumParticles());
    for (int i = 0; i < system.getNumParticles(); ++i)
        masses[i] = system.getParticleMass(i);
}

bool StiffModesMeasurement::measure(ContextImpl& context, int stiffGroups,
                                    const std::function<void(const StiffModes&)>& checkConstraints) {
    ProbedStiffness stiffness = probeStiffness(context, stiffGroups, masses, owner, alternative);
    if (modes && samePotential(stiffness, measured))
        return false;
    std::shared_ptr<const StiffModes> decomposed;
    try {
        decomposed = std::make_shared<const StiffModes>(masses, stiffness.blocks, stiffness.constantForce);
    } catch (const OpenMMException& e) {
        throw OpenMMException(owner + ": " + e.what());
    }
    checkConstraints(*decomposed);
    modes = decomposed;
    measured = stiffness;
    return true;
}
