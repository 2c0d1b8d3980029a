#ifndef OPENMM_FLAVORS_UNION_FIND_H_
#define OPENMM_FLAVORS_UNION_FIND_H_

#include <vector>

namespace FlavorPlugin {

/**
 * The representative of i in a disjoint-set forest (parent[i] == i at a root), halving the path on the way: the
 * connected components of stiff couplings, bonded groups and constraint clusters are all found with it.
 */
inline int findRoot(std::vector<int>& parent, int i) {
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

} // namespace FlavorPlugin

#endif
