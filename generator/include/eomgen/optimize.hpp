// The optimize stage: derived quantities rewritten into the collected form a hand coder writes.
//
// Differentiation leaves sums of products nested the way the sweeps met them: for a planar chain,
// M = Σ mᵢAᵢᵀAᵢ comes out as O(N³) products, where collecting the like terms gives
// Mⱼₖ = aⱼₖ·(sⱼsₖ + cⱼcₖ), O(N²) in all. collect() finds that form without any model-specific
// rule, in four steps over each root:
//
//   expand   every sum, difference, negation and product (and division by a parameter-only
//            node) is expanded, bottom-up in id order, into a polynomial over state atoms:
//            inputs t, q, q̇, q̈, u and the nodes of every other operation (sin, cos, 1/x, ...),
//            whose arguments are collected in turn. A term's coefficient is a node of p alone
//            (a constant once FIXED_PARAMETERS folds the parameters). A node whose expansion
//            would pass max_terms terms stays an atom.
//   simplify like terms merge, and so do the pairs sin²x·R·a + cos²x·R·a = R·a. To see that
//            two coefficients are equal, each is expanded over the parameters and the equal
//            polynomials become one node, written in Horner form over the parameters.
//   factor   terms with the same coefficient (up to sign) share one product by it
//            (distributive law), and each such sum is written in greedy multivariate Horner
//            form: the atom common to most terms is factored out, again and again.
//   keep     the collected roots replace the given ones only when they cost fewer operations per
//            call (operations on p alone are done once per parameter set: the emitter's
//            parameter cache), so the stage never adds work to a call.
//
// Everything is iterative (explicit stacks, no recursion) and ordered by node ids, so the result
// is deterministic. The work is bounded (work_per_node terms per node of the input): a model whose
// expressions do not collect (products of rotations, say) gives up early and keeps its graph.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "eomgen/graph.hpp"

namespace eom::gen {

struct CollectOptions {
  std::size_t max_terms = 1024;     // the largest polynomial kept expanded at a node
  std::size_t work_per_node = 16;  // terms made per node of the input before collect() gives up
};

// Roots equivalent to `roots` (same values up to rounding), in collected form when that is
// cheaper, else `roots` themselves.
std::vector<NodeId> collect(Graph& g, std::span<const NodeId> roots,
                            const CollectOptions& options = {});

}  // namespace eom::gen
