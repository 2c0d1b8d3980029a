#include "ImpulseStepKernel.h"
#include "StiffProbe.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;

ImpulseStepKernel::ImpulseStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : IntegrateStochasticImpulseStepKernel(name, platform), loop(std::move(loop)), configured(false), kT(0.0),
      friction(0.0), stiffKT(0.0), stiffFriction(0.0) {}

void ImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    masses.resize(system.getNumParticles());
    for (int i = 0; i < system.getNumParticles(); ++i)
        masses[i] = system.getParticleMass(i);
}

namespace {

/**
 * Whether two measurements describe the same potential up to the rounding of the probes.  Keeping the old modes
 * then keeps trajectories reproducible (a checkpoint restored elsewhere measures again): eigenvectors of degenerate
 * modes could otherwise rotate with the rounding, and the noise with them.
 */
bool samePotential(const ProbedStiffness& a, const ProbedStiffness& b) {
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
                if (std::abs(a.blocks[n].k[r][c] - b.blocks[n].k[r][c]) > 1e-10 * scale)
                    return false;
    }
    // b = F(q) + K q is measured with the rounding of forces of size ~K |q|: compare on that scale (|q| ~ 1 nm).
    double forceScale = scale;
    for (const Vec3& f : a.constantForce)
        forceScale = std::max(forceScale, std::sqrt(f.dot(f)));
    for (size_t i = 0; i < a.constantForce.size(); ++i) {
        Vec3 d = a.constantForce[i] - b.constantForce[i];
        if (std::sqrt(d.dot(d)) > 1e-10 * forceScale)
            return false;
    }
    return true;
}

} // namespace

void ImpulseStepKernel::measureStiffModes(ContextImpl& context, int stiffGroups) {
    ProbedStiffness stiffness = probeStiffness(context, stiffGroups, masses);
    if (modes && samePotential(stiffness, measured))
        return;
    std::shared_ptr<const StiffModes> decomposed;
    try {
        decomposed = std::make_shared<const StiffModes>(masses, stiffness.blocks, stiffness.constantForce);
    } catch (const OpenMMException& e) {
        throw OpenMMException(std::string("StochasticImpulseIntegrator: ") + e.what());
    }
    std::vector<int> componentOf(masses.size(), -1);
    for (int c = 0; c < decomposed->getNumComponents(); ++c)
        if (decomposed->getComponent(c).stiff)
            for (int k = 0; k < decomposed->getComponent(c).numParticles; ++k)
                componentOf[decomposed->getComponentParticles(c)[k]] = decomposed->getComponentParticles(c)[0];
    rejectConstraintsInsideStiffComponents(context, componentOf);
    modes = decomposed;
    measured = stiffness;
    runner->setStiffModes(modes);
}

void ImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator, bool& forcesValid,
                                bool& stiffModesValid) {
    ImpulseParameters current{integrator.getSplitting(), integrator.getStepSize(), integrator.getStiffGroups(),
                              integrator.getIntegrationForceGroups()};
    const double currentKT = BOLTZ * integrator.getTemperature();
    const double currentStiffKT = BOLTZ * integrator.getStiffModeTemperature();
    if (!configured || !(current == parameters) || currentKT != kT || integrator.getFriction() != friction ||
        currentStiffKT != stiffKT || integrator.getStiffModeFriction() != stiffFriction) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        kT = currentKT;
        friction = integrator.getFriction();
        stiffKT = currentStiffKT;
        stiffFriction = integrator.getStiffModeFriction();
        runner->setSchedule(impulseSchedule(parameters), kT, friction);
        runner->setStiffModeBath(stiffKT, stiffFriction);
        configured = true;
    }
    if (!stiffModesValid || !modes) {
        measureStiffModes(context, parameters.stiffGroups);
        stiffModesValid = true;
    }
    runner->step(context, integrator.getConstraintTolerance(), parameters.stepSize, forcesValid);
}

std::vector<double> ImpulseStepKernel::getStiffModeFrequencies(ContextImpl& context,
                                                               const StochasticImpulseIntegrator& integrator,
                                                               bool& stiffModesValid) {
    if (!stiffModesValid || !modes) {
        measureStiffModes(context, integrator.getStiffGroups());
        stiffModesValid = true;
    }
    return modes->getStiffFrequencies();
}

double ImpulseStepKernel::computeKineticEnergy(ContextImpl& context,
                                               const StochasticImpulseIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

void ImpulseStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    runner->createCheckpoint(stream, "StochasticImpulseIntegrator");
}

void ImpulseStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(context, stream, "StochasticImpulseIntegrator");
}

void ImpulseStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    runner->saveContextState(context, withParameters);
}
