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
    : particles(particles), inverseMasses(particles.inverseMasses), reference(particles.numParticles),
      uncorrected(particles.numParticles) {
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
    // The flow of a free particle: the zero modes' (exact, or Middle's with friction).
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
    carriedComponents.clear();
    carriedMembers.clear();
    stepImpulses.clear();
    if (!modes)
        return;
    // The constrained particle of each stiff component (the API checks allow at most one).
    vector<int> componentOf(particles.numParticles, -1), rowOf(particles.numParticles, -1);
    for (int c = 0; c < modes->getNumComponents(); ++c)
        if (modes->getComponent(c).stiff)
            for (int k = 0; k < modes->getComponent(c).numParticles; ++k) {
                componentOf[modes->getComponentParticles(c)[k]] = c;
                rowOf[modes->getComponentParticles(c)[k]] = k;
            }
    vector<bool> found(modes->getNumComponents(), false);
    for (int c = 0; c < constraintSystem->getNumConstraints(); ++c) {
        int p1, p2;
        double distance;
        constraintSystem->getConstraintParameters(c, p1, p2, distance);
        for (int p : {p1, p2})
            if (componentOf[p] >= 0 && !found[componentOf[p]]) {
                found[componentOf[p]] = true;
                carriedComponents.emplace_back(componentOf[p], rowOf[p]);
            }
    }
    stepImpulses.assign(carriedComponents.size(), Vec3());
    for (const auto& carried : carriedComponents)
        for (int k = 0; k < modes->getComponent(carried.first).numParticles; ++k)
            carriedMembers.push_back(modes->getComponentParticles(carried.first)[k]);
}

vector<int> ConstraintProjector::getCarriers(const StiffModes& modes) const {
    vector<int> carriers;
    for (const auto& carried : carriedComponents)
        carriers.push_back(modes.getComponentParticles(carried.first)[carried.second]);
    return carriers;
}

namespace {

double trace(const double m[3][3]) {
    return m[0][0] + m[1][1] + m[2][2];
}

/** m v for a 3 x 3 matrix m. */
Vec3 times(const double m[3][3], const Vec3& v) {
    Vec3 out;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
            out[a] += m[a][b] * v[b];
    return out;
}

/** out = a b^-1 for 3 x 3 matrices. */
void multiplyByInverse(const double a[3][3], const double b[3][3], double out[3][3]) {
    const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) -
                       b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
                       b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    double inverse[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            // The cofactor of b_ji over det.
            const int r1 = (j + 1) % 3, r2 = (j + 2) % 3, c1 = (i + 1) % 3, c2 = (i + 2) % 3;
            inverse[i][j] = (b[r1][c1] * b[r2][c2] - b[r1][c2] * b[r2][c1]) / det;
        }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            out[i][j] = a[i][0] * inverse[0][j] + a[i][1] * inverse[1][j] + a[i][2] * inverse[2][j];
}

} // namespace

std::shared_ptr<ReferenceConstraints> ConstraintProjector::solverWith(const vector<double>& solveInverseMasses) {
    for (int i = 0; i < particles.numParticles; ++i)
        if (solveInverseMasses[i] != particles.inverseMasses[i])
            constraintSystem->setParticleMass(i, 1.0 / solveInverseMasses[i]);
    auto made = std::make_shared<ReferenceConstraints>(*constraintSystem);
    for (int i = 0; i < particles.numParticles; ++i)
        constraintSystem->setParticleMass(i, particles.masses[i]);
    return made;
}

bool ConstraintProjector::hasCarrying(const SubFlow& flow) {
    return flow.kind == SubFlow::StiffFlow || flow.kind == SubFlow::HarmonicFlow ||
           flow.kind == SubFlow::FilteredStiffFlow || flow.kind == SubFlow::FilteredKick;
}

ConstraintProjector::StiffFlowCarrying ConstraintProjector::carryingThrough(const StiffModes& modes,
                                                                            const SubFlow& flow) {
    // The flow of computePropagator as the executors call it: HarmonicFlow exact, the others as the SubFlow says.
    const bool harmonic = flow.kind == SubFlow::HarmonicFlow;
    const bool filtered = flow.kind == SubFlow::FilteredStiffFlow || flow.kind == SubFlow::FilteredKick;
    StiffModes::ImpulseResponse response;
    modes.computeImpulseResponse(flow.h, flow.bath.friction, flow.stiffBath.friction,
                                 !harmonic && flow.frequency == SubFlow::StiffFrequency::Warped,
                                 !harmonic && flow.zeroModes == SubFlow::ZeroModeFlow::Middle && flow.h > 0,
                                 harmonic ? WarpedFlowSettings() : flow.warp, filtered, flow.response, response);
    const CorrectionScales scales = stiffFlowScales(flow);
    using Block = StiffModes::ImpulseResponse::Block;
    StiffFlowCarrying carrying;
    carrying.velocityPerCorrection = scales.velocity;
    StiffFlowCarrying::Solve &positionSolve = carrying.positions, &velocitySolve = carrying.velocities;
    positionSolve.inverseMasses = velocitySolve.inverseMasses = particles.inverseMasses;
    bool velocitiesCarried = false, processed = false;
    for (size_t k = 0; k < carriedComponents.size(); ++k) {
        const int c = carriedComponents[k].first, row = carriedComponents[k].second;
        const int* members = modes.getComponentParticles(c);
        const int carrier = members[row];
        const double mass = particles.masses[carrier];
        double own[Block::NumBlocks][3][3], blocks[Block::NumBlocks][3][3];
        modes.getImpulseBlocks(response, c, row, row, own);
        // An impulse J on the carrier moves it by X J / m at the flow's end where a free particle moves by J / (m
        // scales.impulse), and its velocity at the end by E J / m: the solves' inverse masses (the mean over
        // directions where the component is anisotropic).
        const double inverseMass = trace(own[Block::ThroughX]) / 3.0 * scales.impulse / mass;
        const double endInverseMass = trace(own[Block::AtEnd]) / 3.0 / mass;
        if (!(inverseMass > 0.0) || !(endInverseMass > 0.0))
            throw OpenMMException("ConstraintProjector: the stiff flow of this step moves constrained particle " +
                                  std::to_string(carrier) +
                                  " against an impulse on it (its constraint correction needs a shorter step)");
        positionSolve.inverseMasses[carrier] = inverseMass;
        velocitySolve.inverseMasses[carrier] = endInverseMass;
        StiffFlowCarrying::Impulse positionImpulse{carrier, (int)k, {}}, endImpulse{carrier, (int)k, {}};
        const double massMatrix[3][3] = {{mass, 0, 0}, {0, mass, 0}, {0, 0, mass}};
        multiplyByInverse(massMatrix, own[Block::ThroughX], positionImpulse.perCorrection);
        multiplyByInverse(massMatrix, own[Block::AtEnd], endImpulse.perCorrection);
        positionSolve.impulses.push_back(positionImpulse);
        velocitySolve.impulses.push_back(endImpulse);
        for (int m = 0; m < modes.getComponent(c).numParticles; ++m) {
            modes.getImpulseBlocks(response, c, m, row, blocks);
            StiffFlowCarrying::Motion motion{members[m], carrier, (int)k, {}, {}};
            multiplyByInverse(blocks[Block::ThroughX], own[Block::ThroughX], motion.position);
            multiplyByInverse(blocks[Block::ThroughV], own[Block::ThroughX], motion.velocity);
            // The carrier's own velocity change is counted with everyone's; here only its difference.
            if (m == row)
                for (int a = 0; a < 3; ++a)
                    motion.velocity[a][a] -= scales.velocity;
            positionSolve.motions.push_back(motion);
            // The step ends with its Filtered kick, whose carrying processes the velocities.
            if (flow.kind == SubFlow::FilteredKick) {
                StiffFlowCarrying::Motion processing{members[m], carrier, (int)k, {}, {}};
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b) {
                        processing.velocity[a][b] = blocks[Block::Processing][a][b] / mass;
                        processed = processed || processing.velocity[a][b] != 0.0;
                    }
                carrying.processing.push_back(processing);
            }
            if (m == row)
                continue;
            StiffFlowCarrying::Motion atEnd{members[m], carrier, (int)k, {}, {}};
            multiplyByInverse(blocks[Block::AtEnd], own[Block::AtEnd], atEnd.velocity);
            velocitySolve.motions.push_back(atEnd);
        }
        // Kicks scaled in some mode (not 1 per unit impulse) make an impulse at the end move the component.
        for (int mode = 0; mode < modes.getComponent(c).rows(); ++mode)
            velocitiesCarried =
                velocitiesCarried || response.data[response.offset[c] + Block::NumBlocks * mode + Block::AtEnd] != 1.0;
    }
    if (!processed)
        carrying.processing.clear();
    // Without constrained stiff components the position solve is the plain one; so is the velocity projection where
    // the step's kicks are plain (an impulse at the end moves the constrained particle alone).
    if (!carriedComponents.empty())
        positionSolve.solver = solverWith(positionSolve.inverseMasses);
    if (velocitiesCarried) {
        velocitySolve.solver = solverWith(velocitySolve.inverseMasses);
    } else {
        velocitySolve.inverseMasses = particles.inverseMasses;
        velocitySolve.motions.clear();
    }
    return carrying;
}

void ConstraintProjector::startStep() {
    std::fill(stepImpulses.begin(), stepImpulses.end(), Vec3());
}

bool ConstraintProjector::hasProcessing(const vector<Vec3>& applied) const {
    return std::any_of(carriedMembers.begin(), carriedMembers.end(), [&](int p) { return applied[p] != Vec3(); });
}

void ConstraintProjector::takeOffProcessing(vector<Vec3>& velocities, vector<Vec3>& applied) const {
    for (int p : carriedMembers) {
        velocities[p] -= applied[p];
        applied[p] = Vec3();
    }
}

void ConstraintProjector::processVelocities(vector<Vec3>& velocities, const StiffFlowCarrying& carrying,
                                            vector<Vec3>& applied) const {
    for (const StiffFlowCarrying::Motion& motion : carrying.processing) {
        const Vec3 change = times(motion.velocity, stepImpulses[motion.carried]);
        velocities[motion.particle] += change;
        applied[motion.particle] += change;
    }
}

void ConstraintProjector::constrainPositions(ContextImpl& context, double tolerance,
                                             const StiffFlowCarrying* carrying) {
    ReferencePlatform::PlatformData& data = platformData(context);
    solvePositions(*data.constraints, *data.positions, *data.velocities, tolerance, carrying);
}

void ConstraintProjector::constrainPositions(vector<Vec3>& positions, vector<Vec3>& velocities, double tolerance,
                                             const StiffFlowCarrying* carrying) {
    solvePositions(ownConstraints(), positions, velocities, tolerance, carrying);
}

void ConstraintProjector::constrainVelocities(ContextImpl& context, double tolerance,
                                              const StiffFlowCarrying* carrying) {
    ReferencePlatform::PlatformData& data = platformData(context);
    solveVelocities(*data.constraints, *data.positions, *data.velocities, tolerance, carrying);
}

void ConstraintProjector::constrainVelocities(vector<Vec3>& positions, vector<Vec3>& velocities, double tolerance,
                                              const StiffFlowCarrying* carrying) {
    solveVelocities(ownConstraints(), positions, velocities, tolerance, carrying);
}

std::pair<ReferenceConstraints*, vector<double>*> ConstraintProjector::solverOf(const StiffFlowCarrying::Solve* solve,
                                                                                ReferenceConstraints& plain) {
    if (solve && solve->solver)
        return {solve->solver.get(), &solve->inverseMasses};
    return {&plain, &inverseMasses};
}

void ConstraintProjector::solvePositions(ReferenceConstraints& plain, vector<Vec3>& positions, vector<Vec3>& velocities,
                                         double tolerance, const StiffFlowCarrying* carrying) {
    const StiffFlowCarrying::Solve* solve = carrying ? &carrying->positions : nullptr;
    const auto solver = solverOf(solve, plain);
    if (solve)
        uncorrected = positions;
    solver.first->apply(reference, positions, *solver.second, tolerance);
    if (!solve)
        return;
    const double velocityScale = carrying->velocityPerCorrection;
    for (int i = 0; i < particles.numParticles; ++i)
        if (particles.inverseMasses[i] != 0.0)
            velocities[i] += (positions[i] - uncorrected[i]) * velocityScale;
    moveCarried(*solve, positions, uncorrected, &positions, velocities);
}

void ConstraintProjector::solveVelocities(ReferenceConstraints& plain, vector<Vec3>& positions,
                                          vector<Vec3>& velocities, double tolerance,
                                          const StiffFlowCarrying* carrying) {
    const StiffFlowCarrying::Solve* solve = carrying ? &carrying->velocities : nullptr;
    const auto solver = solverOf(solve, plain);
    if (solve)
        uncorrected = velocities;
    solver.first->applyToVelocities(positions, velocities, *solver.second, tolerance);
    if (solve)
        moveCarried(*solve, velocities, uncorrected, nullptr, velocities);
}

void ConstraintProjector::moveCarried(const StiffFlowCarrying::Solve& solve, const vector<Vec3>& now,
                                      const vector<Vec3>& before, vector<Vec3>* positions, vector<Vec3>& velocities) {
    for (const StiffFlowCarrying::Impulse& impulse : solve.impulses) {
        stepImpulses[impulse.carried] += times(impulse.perCorrection, now[impulse.carrier] - before[impulse.carrier]);
    }
    for (const StiffFlowCarrying::Motion& motion : solve.motions) {
        const Vec3 correction = now[motion.carrier] - before[motion.carrier];
        if (positions && motion.particle != motion.carrier)
            (*positions)[motion.particle] += times(motion.position, correction);
        velocities[motion.particle] += times(motion.velocity, correction);
    }
}
