/*
 * The part of the preloaded OpenCL test layer that counts what a step asks of the device: kernel launches, buffer
 * reads and writes (blocking ones apart) and host waits.  Tests read the counts through flavorsOpenCLCallCounts()
 * (OpenCLCallCounts.h) before and after some steps.  With FLAVORS_OPENCL_TRACE set, each launch's kernel name goes to
 * stderr (which kernels a step launches, for the benchmarks' breakdowns).
 */
#define CL_TARGET_OPENCL_VERSION 120
#include "OpenCLCallCounts.h"
#include <CL/cl.h>
#include <dlfcn.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>

namespace {

std::atomic<long long> launches{0}, reads{0}, blockingReads{0}, writes{0}, blockingWrites{0}, waits{0};

template <typename Function> Function next(const char* name) {
    return reinterpret_cast<Function>(dlsym(RTLD_NEXT, name));
}

} // namespace

extern "C" {

__attribute__((visibility("default"))) void flavorsOpenCLCallCounts(OpenCLCallCounts* counts) {
    *counts = {launches.load(), reads.load(), blockingReads.load(), writes.load(), blockingWrites.load(), waits.load()};
}

__attribute__((visibility("default"))) cl_int clEnqueueNDRangeKernel(cl_command_queue queue, cl_kernel kernel,
                                                                     cl_uint dimensions, const size_t* offset,
                                                                     const size_t* globalSize, const size_t* localSize,
                                                                     cl_uint numEvents, const cl_event* waitList,
                                                                     cl_event* event) {
    using Launch = cl_int (*)(cl_command_queue, cl_kernel, cl_uint, const size_t*, const size_t*, const size_t*,
                              cl_uint, const cl_event*, cl_event*);
    static const Launch launch = next<Launch>("clEnqueueNDRangeKernel");
    static const bool trace = std::getenv("FLAVORS_OPENCL_TRACE") != nullptr;
    ++launches;
    if (trace) {
        char name[256] = {0};
        clGetKernelInfo(kernel, CL_KERNEL_FUNCTION_NAME, sizeof(name) - 1, name, nullptr);
        std::fprintf(stderr, "launch %s\n", name);
    }
    return launch(queue, kernel, dimensions, offset, globalSize, localSize, numEvents, waitList, event);
}

__attribute__((visibility("default"))) cl_int clEnqueueReadBuffer(cl_command_queue queue, cl_mem buffer,
                                                                  cl_bool blocking, size_t offset, size_t size,
                                                                  void* target, cl_uint numEvents,
                                                                  const cl_event* waitList, cl_event* event) {
    using Read =
        cl_int (*)(cl_command_queue, cl_mem, cl_bool, size_t, size_t, void*, cl_uint, const cl_event*, cl_event*);
    static const Read read = next<Read>("clEnqueueReadBuffer");
    ++reads;
    if (blocking)
        ++blockingReads;
    return read(queue, buffer, blocking, offset, size, target, numEvents, waitList, event);
}

__attribute__((visibility("default"))) cl_int clEnqueueWriteBuffer(cl_command_queue queue, cl_mem buffer,
                                                                   cl_bool blocking, size_t offset, size_t size,
                                                                   const void* source, cl_uint numEvents,
                                                                   const cl_event* waitList, cl_event* event) {
    using Write =
        cl_int (*)(cl_command_queue, cl_mem, cl_bool, size_t, size_t, const void*, cl_uint, const cl_event*, cl_event*);
    static const Write write = next<Write>("clEnqueueWriteBuffer");
    ++writes;
    if (blocking)
        ++blockingWrites;
    return write(queue, buffer, blocking, offset, size, source, numEvents, waitList, event);
}

__attribute__((visibility("default"))) cl_int clFinish(cl_command_queue queue) {
    using Finish = cl_int (*)(cl_command_queue);
    static const Finish finish = next<Finish>("clFinish");
    ++waits;
    return finish(queue);
}

__attribute__((visibility("default"))) cl_int clWaitForEvents(cl_uint numEvents, const cl_event* events) {
    using Wait = cl_int (*)(cl_uint, const cl_event*);
    static const Wait wait = next<Wait>("clWaitForEvents");
    ++waits;
    return wait(numEvents, events);
}

} // extern "C"
