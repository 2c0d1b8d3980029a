#ifndef OPENMM_FLAVORS_COMPAT_LEPTON_CUSTOM_FUNCTION_H_
#define OPENMM_FLAVORS_COMPAT_LEPTON_CUSTOM_FUNCTION_H_

/*
 * Compatibility header, not Lepton: Debian's libopenmm-dev omits OpenMM's lepton/ headers, which
 * openmm/common/ExpressionUtilities.h (included by the OpenCL platform's headers) includes.  That header only derives
 * a placeholder from Lepton::CustomFunction and names the other Lepton classes by reference, so this declares the
 * abstract interface as OpenMM 7.7 has it and nothing else.  This plugin never parses expressions.
 */
namespace Lepton {

class CustomFunction {
public:
    virtual ~CustomFunction() {}
    virtual int getNumArguments() const = 0;
    virtual double evaluate(const double* arguments) const = 0;
    virtual double evaluateDerivative(const double* arguments, const int* derivOrder) const = 0;
    virtual CustomFunction* clone() const = 0;
};

} // namespace Lepton

#endif
