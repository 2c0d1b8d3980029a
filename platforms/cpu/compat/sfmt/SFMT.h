// Debian's OpenMM headers omit sfmt/; the CPU platform headers only use this type through pointers.
#ifndef OPENMM_FLAVORS_SFMT_COMPAT_H_
#define OPENMM_FLAVORS_SFMT_COMPAT_H_
namespace OpenMM_SFMT {
class SFMT;
}
#endif
