#ifndef OPENMM_FLAVORS_OPENCL_CALL_COUNTS_H_
#define OPENMM_FLAVORS_OPENCL_CALL_COUNTS_H_

/**
 * What the preloaded OpenCL test layer (OpenCLCallCounts.cpp) has counted since the process started: kernel launches,
 * buffer reads and writes (those that block the host apart), and host waits for the queue (clFinish,
 * clWaitForEvents).  Counts do not depend on the machine's load, so tests may assert them.
 */
struct OpenCLCallCounts {
    long long launches, reads, blockingReads, writes, blockingWrites, waits;
};

/** The symbol the layer exports: fills counts.  Look it up with dlsym(RTLD_DEFAULT, OpenCLCallCountsSymbol). */
using OpenCLCallCountsFunction = void (*)(OpenCLCallCounts* counts);
constexpr const char* OpenCLCallCountsSymbol = "flavorsOpenCLCallCounts";

#endif
