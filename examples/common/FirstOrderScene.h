#ifndef OPENMM_FLAVORS_FIRST_ORDER_SCENE_H_
#define OPENMM_FLAVORS_FIRST_ORDER_SCENE_H_

// What the C++ programs of the first-order scenes (examples/van_der_pol, examples/hidden_sde) share: "--name value"
// arguments, a JSON object on stdout, a wall clock and progress lines on stderr.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace FirstOrderScene {

/** The program's arguments "--name value ..." with their defaults; an unknown name is an error. */
class Arguments {
public:
    Arguments(int argc, char** argv, std::map<std::string, std::string> defaults) : values(std::move(defaults)) {
        for (int i = 1; i < argc; i += 2) {
            const std::string name = argv[i];
            if (name.rfind("--", 0) != 0 || i + 1 >= argc || values.count(name.substr(2)) == 0)
                throw std::invalid_argument("unknown or incomplete argument " + name);
            values[name.substr(2)] = argv[i + 1];
        }
    }
    std::string text(const std::string& name) const { return values.at(name); }
    double number(const std::string& name) const { return std::stod(values.at(name)); }
    long long integer(const std::string& name) const { return std::stoll(values.at(name)); }

private:
    std::map<std::string, std::string> values;
};

/**
 * Wall and processor seconds since construction.  The programs run on one thread, so the processor time is the work
 * done, whatever else the machine runs at the same time; the wall time is what a user waits.
 */
class Clock {
public:
    Clock() : start(std::chrono::steady_clock::now()), cpuStart(std::clock()) {}
    double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
    double cpuSeconds() const { return (double)(std::clock() - cpuStart) / CLOCKS_PER_SEC; }

private:
    std::chrono::steady_clock::time_point start;
    std::clock_t cpuStart;
};

/** A line on stderr at most every two seconds: "  label: done / total (percent), seconds". */
class Progress {
public:
    explicit Progress(std::string label) : label(std::move(label)) {}
    void update(double done, double total) {
        const double now = clock.seconds();
        if (now - last < 2.0)
            return;
        last = now;
        std::fprintf(stderr, "  %s: %.4g / %.4g (%5.1f%%) %6.1f s\n", label.c_str(), done, total, 100 * done / total,
                     now);
        std::fflush(stderr);
    }

private:
    std::string label;
    Clock clock;
    double last = 0;
};

/** One JSON object on stdout, written member by member (non-finite numbers as null). */
class JsonWriter {
public:
    JsonWriter() { std::printf("{"); }
    ~JsonWriter() { std::printf("}\n"); }
    void number(const char* name, double value) {
        key(name);
        write(value);
    }
    void text(const char* name, const std::string& value) {
        key(name);
        std::printf("\"%s\"", value.c_str());
    }
    void array(const char* name, const std::vector<double>& values) {
        key(name);
        std::printf("[");
        for (std::size_t i = 0; i < values.size(); ++i) {
            if (i)
                std::printf(",");
            write(values[i]);
        }
        std::printf("]");
    }

private:
    void key(const char* name) {
        std::printf("%s\"%s\":", first ? "" : ",", name);
        first = false;
    }
    static void write(double value) {
        if (std::isfinite(value))
            std::printf("%.17g", value);
        else
            std::printf("null");
    }
    bool first = true;
};

} // namespace FirstOrderScene

#endif
