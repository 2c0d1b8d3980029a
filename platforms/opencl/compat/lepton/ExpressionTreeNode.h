#ifndef OPENMM_FLAVORS_COMPAT_LEPTON_EXPRESSION_TREE_NODE_H_
#define OPENMM_FLAVORS_COMPAT_LEPTON_EXPRESSION_TREE_NODE_H_

// Compatibility header (see CustomFunction.h): openmm/common/ExpressionUtilities.h names this class by reference only.
namespace Lepton {
class ExpressionTreeNode;
}

#endif
