// Declares the OpenMM base class this module's integrators derive from.  Debian ships none of OpenMM's SWIG
// interface files; importing this one lets the generated proxies derive from openmm.openmm.Integrator, so
// openmm.Context accepts them.
%module(package="openmm") openmm

namespace OpenMM {
class Integrator {
public:
    virtual ~Integrator();
};
}
