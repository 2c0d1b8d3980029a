#ifndef OPENMM_FLAVORS_WINDOWSEXPORT_H_
#define OPENMM_FLAVORS_WINDOWSEXPORT_H_

/*
 * Shared libraries are built with hidden symbol visibility; the public API is exported explicitly.
 */
#if defined(_MSC_VER)
#if defined(OPENMM_FLAVORS_BUILDING_SHARED_LIBRARY)
#define OPENMM_EXPORT_FLAVORS __declspec(dllexport)
#else
#define OPENMM_EXPORT_FLAVORS __declspec(dllimport)
#endif
#else
#define OPENMM_EXPORT_FLAVORS __attribute__((visibility("default")))
#endif

#endif
