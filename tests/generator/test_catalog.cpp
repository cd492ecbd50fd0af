// The generator's kernel table (eomgen/kernels.hpp: what it emits) and the runtime's kernel catalog
// (eom/model/kernels.hpp: what integrators and RequireKernels expect) list the same kernels, in the same
// order, with the same results, argument names and default/on-request/per-frame/per-set status.
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <string_view>

#include <eom/model/kernels.hpp>
#include <eomgen/kernels.hpp>

namespace {

using namespace eom::gen;

struct RuntimeRow {
  std::string_view name, result, arguments, when;
};
constexpr std::array runtime_catalog{
#define EOM_TEST_ROW(name, Concept, result, parameters, arguments, members, when) \
  RuntimeRow{#name, #result, #arguments, #when},
    EOM_KERNEL_CATALOG(EOM_TEST_ROW)
#undef EOM_TEST_ROW
};

// "(a, b, c)": the generator's argument names of kernel k in signature order.
std::string argument_list(KernelId k) {
  const Signature& s = signature(k);
  std::string out = "(";
  auto add = [&](std::string_view n) { out += (out.size() > 1 ? ", " : "") + std::string(n); };
  for (const auto& e : s.leading) add(e.name);
  for (InputKind in : s.inputs) add(name(in));
  for (const auto& o : s.outputs)
    if (s.result != "double") add(o.name);  // a double kernel returns its one output
  for (const auto& e : s.trailing) add(e.name);
  return out + ")";
}

TEST(KernelCatalog, GeneratorAndRuntimeListTheSameKernels) {
  ASSERT_EQ(runtime_catalog.size(), static_cast<std::size_t>(kernel_count));
  for (int i = 0; i < kernel_count; ++i) {
    const auto k = static_cast<KernelId>(i);
    const RuntimeRow& row = runtime_catalog[i];
    SCOPED_TRACE(std::string(row.name));
    EXPECT_EQ(signature(k).name, row.name);
    EXPECT_EQ(signature(k).result, row.result);
    EXPECT_EQ(argument_list(k), row.arguments);
    EXPECT_EQ(on_request_only(k), row.when == "on_request");
    EXPECT_EQ(per_frame(k), row.when == "with_frames");
    EXPECT_EQ(per_contact_set(k), row.when == "with_contacts");
    EXPECT_EQ(kernel_from_name(row.name), k);
  }
}

}  // namespace
