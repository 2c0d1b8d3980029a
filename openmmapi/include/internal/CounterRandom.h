#ifndef OPENMM_FLAVORS_COUNTER_RANDOM_H_
#define OPENMM_FLAVORS_COUNTER_RANDOM_H_

#include <array>
#include <cmath>
#include <cstdint>
#include <random>

namespace FlavorPlugin {

/**
 * Counter-based Gaussian random numbers (Philox4x32-10, Salmon et al., SC'11).  The numbers for a (stream,
 * particle) pair depend only on the seed, so any thread may draw them in any order: trajectories do not depend
 * on the number of threads or on the platform, and the random state is just the stream counter.
 */
class CounterRandom {
public:
    explicit CounterRandom(std::uint64_t seed = 0) : key0((std::uint32_t)seed), key1((std::uint32_t)(seed >> 32)) {}

    /** Three independent standard normal numbers for one particle in one stream. */
    std::array<double, 3> normals(std::uint64_t stream, std::uint32_t particle) const {
        std::array<std::uint32_t, 4> bits = philox({(std::uint32_t)stream, (std::uint32_t)(stream >> 32), particle, 0});
        double u0 = uniformOpen(bits[0]), u1 = uniformOpen(bits[1]), u2 = uniformOpen(bits[2]),
               u3 = uniformOpen(bits[3]);
        double r0 = std::sqrt(-2.0 * std::log(u0)), r1 = std::sqrt(-2.0 * std::log(u2));
        const double twoPi = 6.283185307179586476925286766559;
        return {r0 * std::cos(twoPi * u1), r0 * std::sin(twoPi * u1), r1 * std::cos(twoPi * u3)};
    }

private:
    static double uniformOpen(std::uint32_t x) {
        // (x + 0.5) / 2^32 lies strictly inside (0, 1), so the logarithm is finite.
        return (x + 0.5) * (1.0 / 4294967296.0);
    }

    std::array<std::uint32_t, 4> philox(std::array<std::uint32_t, 4> c) const {
        std::uint32_t k0 = key0, k1 = key1;
        for (int round = 0; round < 10; ++round) {
            std::uint64_t p0 = (std::uint64_t)0xD2511F53u * c[0];
            std::uint64_t p1 = (std::uint64_t)0xCD9E8D57u * c[2];
            c = {(std::uint32_t)(p1 >> 32) ^ c[1] ^ k0, (std::uint32_t)p1, (std::uint32_t)(p0 >> 32) ^ c[3] ^ k1,
                 (std::uint32_t)p0};
            k0 += 0x9E3779B9u;
            k1 += 0xBB67AE85u;
        }
        return c;
    }

    std::uint32_t key0, key1;
};

/** Turns a user's seed into the seed of the random streams, as OpenMM's integrators do: 0 picks a fresh one. */
inline std::uint64_t effectiveRandomSeed(int seed) {
    if (seed != 0)
        return (std::uint64_t)(std::uint32_t)seed;
    std::random_device device;
    return ((std::uint64_t)device() << 32) | device();
}

} // namespace FlavorPlugin

#endif
