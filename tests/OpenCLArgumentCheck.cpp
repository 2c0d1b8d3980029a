/*
 * A preloaded layer over the OpenCL library that checks every kernel argument as NVIDIA's driver does, so that the
 * OpenCL tests catch on PoCL what only a GPU would refuse.  PoCL accepts a scalar argument of the wrong size (a double
 * where a single-precision Context compiled `mixed` as float) and reads it as it lands; NVIDIA's driver answers
 * CL_INVALID_ARG_SIZE.  Here such a call prints what is wrong and gets CL_INVALID_ARG_SIZE, a buffer of another OpenCL
 * context CL_INVALID_MEM_OBJECT, as on the GPU.
 *
 *     LD_PRELOAD=build/tests/libOpenCLArgumentCheck.so build/tests/TestFlavorsPlatforms --gtest_filter='*OpenCL*'
 *
 * Programs are built with -cl-kernel-arg-info added, so that the arguments' declared types can be read back; the
 * typedefs OpenMM's kernels use (real, mixed and their vectors, mm_long, ...) are resolved from the program's source.
 */
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <dlfcn.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

/** Bytes of an OpenCL C scalar or vector type ("float", "double4", "uint"); 0 when unknown. */
size_t bytesOf(std::string type) {
    int lanes = 1;
    size_t digits = type.size();
    while (digits > 0 && type[digits - 1] >= '0' && type[digits - 1] <= '9')
        --digits;
    if (digits < type.size()) {
        lanes = std::stoi(type.substr(digits));
        if (lanes == 3)
            lanes = 4; // a 3-vector is stored as a 4-vector
        type.resize(digits);
    }
    size_t element = 0;
    if (type == "char" || type == "uchar" || type == "unsigned char")
        element = 1;
    else if (type == "short" || type == "ushort" || type == "unsigned short" || type == "half")
        element = 2;
    else if (type == "int" || type == "uint" || type == "unsigned int" || type == "float")
        element = 4;
    else if (type == "long" || type == "ulong" || type == "unsigned long" || type == "double")
        element = 8;
    return element * lanes;
}

/** The program's source, or "" when the program was built from binaries. */
std::string sourceOf(cl_kernel kernel) {
    cl_program program = nullptr;
    size_t length = 0;
    if (clGetKernelInfo(kernel, CL_KERNEL_PROGRAM, sizeof(program), &program, nullptr) != CL_SUCCESS ||
        clGetProgramInfo(program, CL_PROGRAM_SOURCE, 0, nullptr, &length) != CL_SUCCESS || length == 0)
        return "";
    std::vector<char> text(length);
    clGetProgramInfo(program, CL_PROGRAM_SOURCE, length, text.data(), nullptr);
    return std::string(text.data());
}

/** The bytes a declared argument type takes, resolving OpenMM's typedefs (real, mixed) and mm_ names. */
size_t declaredBytes(cl_kernel kernel, const std::string& type) {
    if (size_t bytes = bytesOf(type))
        return bytes;
    if (type.compare(0, 3, "mm_") == 0)
        return bytesOf(type.substr(3));
    for (const char* alias : {"mixed", "real"}) {
        const size_t n = std::strlen(alias);
        if (type.compare(0, n, alias) != 0)
            continue;
        const std::string source = sourceOf(kernel), vector = type.substr(n);
        for (const char* primitive : {"double", "float"})
            if (source.find(std::string("typedef ") + primitive + " " + alias + ";") != std::string::npos)
                return bytesOf(primitive + vector);
    }
    return 0;
}

std::string nameOf(cl_kernel kernel) {
    char name[256] = "";
    clGetKernelInfo(kernel, CL_KERNEL_FUNCTION_NAME, sizeof(name), name, nullptr);
    return name;
}

template <typename Function> Function next(const char* name) {
    return reinterpret_cast<Function>(dlsym(RTLD_NEXT, name));
}

} // namespace

extern "C" {

__attribute__((visibility("default"))) cl_int clBuildProgram(cl_program program, cl_uint numDevices,
                                                             const cl_device_id* devices, const char* options,
                                                             void(CL_CALLBACK* notify)(cl_program, void*), void* data) {
    using Build =
        cl_int (*)(cl_program, cl_uint, const cl_device_id*, const char*, void(CL_CALLBACK*)(cl_program, void*), void*);
    static const Build build = next<Build>("clBuildProgram");
    const std::string withInfo = std::string(options ? options : "") + " -cl-kernel-arg-info";
    return build(program, numDevices, devices, withInfo.c_str(), notify, data);
}

__attribute__((visibility("default"))) cl_int clSetKernelArg(cl_kernel kernel, cl_uint index, size_t size,
                                                             const void* value) {
    using Set = cl_int (*)(cl_kernel, cl_uint, size_t, const void*);
    static const Set set = next<Set>("clSetKernelArg");
    cl_kernel_arg_address_qualifier space = 0;
    char type[256] = "";
    if (clGetKernelArgInfo(kernel, index, CL_KERNEL_ARG_ADDRESS_QUALIFIER, sizeof(space), &space, nullptr) ==
            CL_SUCCESS &&
        clGetKernelArgInfo(kernel, index, CL_KERNEL_ARG_TYPE_NAME, sizeof(type), type, nullptr) == CL_SUCCESS) {
        if (space == CL_KERNEL_ARG_ADDRESS_PRIVATE) {
            const size_t declared = declaredBytes(kernel, type);
            if (declared != 0 && declared != size) {
                std::fprintf(stderr, "OpenCLArgumentCheck: kernel %s, argument %u (%s, %zu bytes) set with %zu bytes\n",
                             nameOf(kernel).c_str(), index, type, declared, size);
                return CL_INVALID_ARG_SIZE;
            }
        } else if ((space == CL_KERNEL_ARG_ADDRESS_GLOBAL || space == CL_KERNEL_ARG_ADDRESS_CONSTANT) && value &&
                   size == sizeof(cl_mem) && *static_cast<const cl_mem*>(value)) {
            cl_context kernelContext = nullptr, bufferContext = nullptr;
            clGetKernelInfo(kernel, CL_KERNEL_CONTEXT, sizeof(kernelContext), &kernelContext, nullptr);
            if (clGetMemObjectInfo(*static_cast<const cl_mem*>(value), CL_MEM_CONTEXT, sizeof(bufferContext),
                                   &bufferContext, nullptr) == CL_SUCCESS &&
                bufferContext != kernelContext) {
                std::fprintf(stderr, "OpenCLArgumentCheck: kernel %s, argument %u (%s): a buffer of another context\n",
                             nameOf(kernel).c_str(), index, type);
                return CL_INVALID_MEM_OBJECT;
            }
        }
    }
    return set(kernel, index, size, value);
}

} // extern "C"
