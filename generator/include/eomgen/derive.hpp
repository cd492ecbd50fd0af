// Symbolic differentiation on the DAG: every derivative is itself a set of new nodes of the same
// graph, so it is simplified, shared and emitted like any traced expression.
//
// Both modes share one rule table (the local partial of each operation, applied to an incoming
// tangent or adjoint) and both sweep the cone of their roots in id order, without recursion.
// Only "active" nodes (those that depend on the seeded or requested inputs) get a derivative, so
// a derivative never creates nodes for a subexpression that is constant in the direction taken.
#pragma once

#include <span>
#include <utility>
#include <vector>

#include "eomgen/graph.hpp"

namespace eom::gen {

using Seed = std::pair<NodeId, NodeId>;  // (node, the node that replaces it or its tangent)

// Reverse mode: ∂f/∂x for each x in wrt, as nodes (Graph::zero where f does not depend on x).
// One sweep gives the whole gradient: the choice for scalar functions of many inputs.
std::vector<NodeId> gradient(Graph& g, NodeId f, std::span<const NodeId> wrt);

// Forward mode: Σⱼ ∂yᵢ/∂xⱼ ẋⱼ for each output yᵢ, with seeds (xⱼ, ẋⱼ). One sweep gives one
// directional derivative of every output: the choice for many outputs along one direction.
std::vector<NodeId> directional(Graph& g, std::span<const NodeId> outputs,
                                std::span<const Seed> seeds);

// The outputs rebuilt with each seed's node replaced by its partner (e.g. q̇ by 0), simplified.
std::vector<NodeId> substitute(Graph& g, std::span<const NodeId> outputs,
                               std::span<const Seed> replacements);

}  // namespace eom::gen
