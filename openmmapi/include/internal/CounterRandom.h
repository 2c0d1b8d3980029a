#ifndef OPENMM_FLAVORS_COUNTER_RANDOM_H_
#define OPENMM_FLAVORS_COUNTER_RANDOM_H_

#include <array>
#include <cmath>
#include <cstdint>
#include <random>

namespace FlavorPlugin {

/**
 * The tables of the 128-layer ziggurat for the standard normal distribution (Marsaglia and Tsang, J. Stat. Softw.
 * 5(8), 2000), for 32-bit signed values.
 */
struct ZigguratTables {
    /** The rightmost layer's edge: beyond it lies the tail. */
    static constexpr double TailStart = 3.442619855899;
    std::uint32_t kn[128];
    double wn[128], fn[128];

    ZigguratTables() {
        const double m1 = 2147483648.0, area = 9.91256303526217e-3;
        double dn = TailStart, tn = dn;
        const double q = area / std::exp(-0.5 * dn * dn);
        kn[0] = (std::uint32_t)((dn / q) * m1);
        kn[1] = 0;
        wn[0] = q / m1;
        wn[127] = dn / m1;
        fn[0] = 1.0;
        fn[127] = std::exp(-0.5 * dn * dn);
        for (int i = 126; i >= 1; --i) {
            dn = std::sqrt(-2.0 * std::log(area / dn + std::exp(-0.5 * dn * dn)));
            kn[i + 1] = (std::uint32_t)((dn / tn) * m1);
            tn = dn;
            fn[i] = std::exp(-0.5 * dn * dn);
            wn[i] = dn / m1;
        }
    }
    static const ZigguratTables& get() {
        static const ZigguratTables tables;
        return tables;
    }
};

/**
 * Counter-based Gaussian random numbers: Philox4x32-10 (Salmon et al., SC'11) turned into normals by the ziggurat
 * method.  The numbers for a (stream, particle) pair depend only on the seed, so any thread may draw them in any
 * order: trajectories do not depend on the number of threads or on the platform, and the random state is just the
 * stream counter.
 */
class CounterRandom {
public:
    explicit CounterRandom(std::uint64_t seed = 0)
        : key0((std::uint32_t)seed), key1((std::uint32_t)(seed >> 32)), tables(&ZigguratTables::get()) {}

    /** A uniform number in (0, 1) for a stream (a Metropolis test's; the counter's last word tells it from normals). */
    double uniform(std::uint64_t stream) const {
        return uniformOpen(philox({(std::uint32_t)stream, (std::uint32_t)(stream >> 32), 0, 1})[0]);
    }

    /** Three independent standard normal numbers for one particle in one stream. */
    std::array<double, 3> normals(std::uint64_t stream, std::uint32_t particle) const {
        // One block: three 32-bit values, and the layer of each from separate bits of the fourth word (layer and
        // value drawn from the same bits correlate, Doornik 2005).  The rare values that fall outside their layer's
        // box draw further blocks of the same counter.
        const std::array<std::uint32_t, 4> bits =
            philox({(std::uint32_t)stream, (std::uint32_t)(stream >> 32), particle, 0});
        Spare spare{this, {(std::uint32_t)stream, (std::uint32_t)(stream >> 32), particle, 0}, {}, 4};
        std::array<double, 3> result;
        for (int k = 0; k < 3; ++k)
            result[k] = normal((std::int32_t)bits[k], (bits[3] >> (7 * k)) & 127, spare);
        return result;
    }

private:
    /** Further random words for the same counter, one block at a time, drawn only when needed. */
    struct Spare {
        const CounterRandom* random;
        std::array<std::uint32_t, 4> counter;
        std::array<std::uint32_t, 4> words;
        int used;
        std::uint32_t next() {
            if (used == 4) {
                counter[3]++;
                words = random->philox(counter);
                used = 0;
            }
            return words[used++];
        }
    };

    double normal(std::int32_t value, std::uint32_t layer, Spare& spare) const {
        const ZigguratTables& t = *tables;
        for (;;) {
            const std::int64_t magnitude = value < 0 ? -(std::int64_t)value : (std::int64_t)value;
            const double x = value * t.wn[layer];
            if (magnitude < (std::int64_t)t.kn[layer])
                return x; // inside the layer's box: about 99 % of all draws
            if (layer == 0) {
                // The tail beyond TailStart (Marsaglia 1964).
                double tailX, tailY;
                do {
                    tailX = -std::log(uniformOpen(spare.next())) / ZigguratTables::TailStart;
                    tailY = -std::log(uniformOpen(spare.next()));
                } while (tailY + tailY < tailX * tailX);
                return value > 0 ? ZigguratTables::TailStart + tailX : -ZigguratTables::TailStart - tailX;
            }
            // The wedge between the box and the density.
            if (t.fn[layer] + uniformOpen(spare.next()) * (t.fn[layer - 1] - t.fn[layer]) < std::exp(-0.5 * x * x))
                return x;
            value = (std::int32_t)spare.next();
            layer = spare.next() & 127;
        }
    }

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
    const ZigguratTables* tables;
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
