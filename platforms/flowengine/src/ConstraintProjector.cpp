#include "ConstraintProjector.h"
#include "internal/ExactModeFlow.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/ReferenceConstraints.h"
#include "openmm/reference/ReferencePlatform.h"
#include <algorithm>
#include <cmath>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

ReferencePlatform::PlatformData& platformData(ContextImpl& context) {
    return *reinterpret_cast<ReferencePlatform::PlatformData*>(context.getPlatformData());
}

} // namespace

ConstraintProjector::ConstraintProjector(const System& system, const ParticleTable& particles, bool ownSolver)
    : particles(particles), inverseMasses(particles.inverseMasses), reference(particles.numParticles) {
    constraintSystem = std::make_unique<System>();
    for (int i = 0; i < particles.numParticles; ++i)
        constraintSystem->addParticle(particles.masses[i]);
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        system.getConstraintParameters(c, p1, p2, distance);
        constraintSystem->addConstraint(p1, p2, distance);
    }
    for (int f = 0; f < system.getNumForces(); ++f)
        if (const auto* angles = dynamic_cast<const HarmonicAngleForce*>(&system.getForce(f))) {
            HarmonicAngleForce* copy = new HarmonicAngleForce();
            for (int a = 0; a < angles->getNumAngles(); ++a) {
                int p1, p2, p3;
                double angle, k;
                angles->getAngleParameters(a, p1, p2, p3, angle, k);
                copy->addAngle(p1, p2, p3, angle, k);
            }
            constraintSystem->addForce(copy);
        }
    if (ownSolver)
        solver = std::make_unique<ReferenceConstraints>(*constraintSystem);
}

ConstraintProjector::~ConstraintProjector() = default;

ConstraintProjector::CorrectionScales ConstraintProjector::stiffFlowScales(const SubFlow& flow) {
    // Constrained particles are free particles or carry their component as a rigid body: zero modes.
    const bool middleFlow = flow.zeroModes == SubFlow::ZeroModeFlow::Middle && flow.h > 0;
    const double friction = flow.bath.friction;
    const ModeFlow zeroMode = middleFlow ? computeMiddleFreeFlow(friction, flow.h)
                                         : computeModeFlow(0.0, flow.h > 0 ? friction : 0.0, std::abs(flow.h));
    CorrectionScales scales;
    scales.impulse = 1.0 / (flow.h > 0 ? zeroMode.xv : -zeroMode.xv);
    scales.velocity = zeroMode.vv * scales.impulse;
    return scales;
}

void ConstraintProjector::rejectUncarriedConstraints(const ContextImpl& context, const StiffModes& modes) {
    vector<int> componentOf(context.getSystem().getNumParticles(), -1);
    for (int c = 0; c < modes.getNumComponents(); ++c)
        if (modes.getComponent(c).stiff)
            for (int k = 0; k < modes.getComponent(c).numParticles; ++k)
                componentOf[modes.getComponentParticles(c)[k]] = modes.getComponentParticles(c)[0];
    rejectConstraintsInsideStiffComponents(context, componentOf);
}

ReferenceConstraints& ConstraintProjector::ownConstraints() {
    if (!solver)
        throw OpenMMException("ConstraintProjector: solves on vectors need a projector built with its own solver");
    return *solver;
}

void ConstraintProjector::setStiffModes(const StiffModes* modes) {
    carriedConstraints.reset();
    carriedParticles.clear();
    if (modes) {
        // The constrained particle of each stiff component (the API checks allow at most one) carries the others.
        vector<int> componentOf(particles.numParticles, -1);
        for (int c = 0; c < modes->getNumComponents(); ++c)
            if (modes->getComponent(c).stiff)
                for (int k = 0; k < modes->getComponent(c).numParticles; ++k)
                    componentOf[modes->getComponentParticles(c)[k]] = c;
        vector<int> carrierOf(modes->getNumComponents(), -1);
        for (int c = 0; c < constraintSystem->getNumConstraints(); ++c) {
            int p1, p2;
            double distance;
            constraintSystem->getConstraintParameters(c, p1, p2, distance);
            for (int p : {p1, p2})
                if (componentOf[p] >= 0)
                    carrierOf[componentOf[p]] = p;
        }
        carriedInverseMasses = particles.inverseMasses;
        for (int c = 0; c < modes->getNumComponents(); ++c) {
            const int carrier = carrierOf[c];
            if (carrier < 0)
                continue;
            double total = 0;
            for (int k = 0; k < modes->getComponent(c).numParticles; ++k) {
                const int p = modes->getComponentParticles(c)[k];
                total += particles.masses[p];
                if (p != carrier)
                    carriedParticles.emplace_back(p, carrier);
            }
            carriedInverseMasses[carrier] = 1.0 / total;
            constraintSystem->setParticleMass(carrier, total);
        }
        if (!carriedParticles.empty())
            carriedConstraints = std::make_unique<ReferenceConstraints>(*constraintSystem);
        for (int i = 0; i < particles.numParticles; ++i)
            constraintSystem->setParticleMass(i, particles.masses[i]);
        carrierBefore.resize(carriedParticles.size());
    }
    carrierImpulses.assign(carriedParticles.size(), Vec3());
    shareParticles.clear();
    for (const auto& pair : carriedParticles)
        for (int p : {pair.first, pair.second})
            if (std::find(shareParticles.begin(), shareParticles.end(), p) == shareParticles.end())
                shareParticles.push_back(p);
}

void ConstraintProjector::constrainPositions(ContextImpl& context, double tolerance, double impulsePerCorrection) {
    ReferencePlatform::PlatformData& data = platformData(context);
    solvePositions(*data.constraints, *data.positions, tolerance, impulsePerCorrection);
}

void ConstraintProjector::constrainPositions(vector<Vec3>& positions, double tolerance, double impulsePerCorrection) {
    solvePositions(ownConstraints(), positions, tolerance, impulsePerCorrection);
}

void ConstraintProjector::constrainVelocities(ContextImpl& context, double tolerance) {
    ReferencePlatform::PlatformData& data = platformData(context);
    solveVelocities(*data.constraints, *data.positions, *data.velocities, tolerance);
}

void ConstraintProjector::constrainVelocities(vector<Vec3>& positions, vector<Vec3>& velocities, double tolerance) {
    solveVelocities(ownConstraints(), positions, velocities, tolerance);
}

void ConstraintProjector::solvePositions(ReferenceConstraints& uncarried, vector<Vec3>& positions, double tolerance,
                                         double impulsePerCorrection) {
    if (!carriedConstraints) {
        uncarried.apply(reference, positions, inverseMasses, tolerance);
        return;
    }
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        carrierBefore[k] = positions[carriedParticles[k].second];
    carriedConstraints->apply(reference, positions, carriedInverseMasses, tolerance);
    addCarrierImpulses(positions, impulsePerCorrection);
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        positions[carriedParticles[k].first] += positions[carriedParticles[k].second] - carrierBefore[k];
}

void ConstraintProjector::solveVelocities(ReferenceConstraints& uncarried, vector<Vec3>& positions,
                                          vector<Vec3>& velocities, double tolerance) {
    if (!carriedConstraints) {
        uncarried.applyToVelocities(positions, velocities, inverseMasses, tolerance);
        return;
    }
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        carrierBefore[k] = velocities[carriedParticles[k].second];
    carriedConstraints->applyToVelocities(positions, velocities, carriedInverseMasses, tolerance);
    addCarrierImpulses(velocities, 1.0);
    for (size_t k = 0; k < carriedParticles.size(); ++k)
        velocities[carriedParticles[k].first] += velocities[carriedParticles[k].second] - carrierBefore[k];
}

void ConstraintProjector::addCarrierImpulses(const vector<Vec3>& corrected, double impulsePerCorrection) {
    for (size_t k = 0; k < carriedParticles.size(); ++k) {
        const int carrier = carriedParticles[k].second;
        carrierImpulses[k] +=
            (corrected[carrier] - carrierBefore[k]) * (impulsePerCorrection / carriedInverseMasses[carrier]);
    }
}

void ConstraintProjector::takeShares(double stepSize, vector<Vec3>& shareForces) {
    if (carriedParticles.empty())
        return;
    // The carrier's mean constraint force over the step is J / stepSize; carrying gave the carried particle the
    // share m_p / M of it, which the true dynamics gives the carrier.
    for (int p : shareParticles)
        shareForces[p] = Vec3();
    for (size_t k = 0; k < carriedParticles.size(); ++k) {
        const int carried = carriedParticles[k].first, carrier = carriedParticles[k].second;
        const Vec3 share = carrierImpulses[k] * (-particles.masses[carried] * carriedInverseMasses[carrier] / stepSize);
        shareForces[carried] += share;
        shareForces[carrier] -= share;
        carrierImpulses[k] = Vec3();
    }
}
