// Python bindings of a generated model, written once over its `Kernels` type (docs/CONTRACT.md §3):
// add_eom_model(<name> ... PYTHON) compiles a two-line source per model,
//
//   #include "<name>.hpp"
//   #include "eom_python.hpp"
//   PYBIND11_MODULE(<module>, m) { eom::python::bind_model<::<ns>::Kernels>(m, "<name>"); }
//
// into a pybind11 extension module. What the module offers (python/README.md has the manual):
//
// - sizes nq, nv, nu, np, nc, nframes, state_size (nq + nv), batch_lanes; names parameter_names,
//   frame_names, coordinate_names, velocity_names, input_names (tuples), parameter_values and
//   the limits position_lower/upper, effort_limit, velocity_limit (read-only float64 arrays; the
//   names and limits where the Kernels type has them, as generated headers do), kernels (the
//   names of the kernels it has),
//   parameters(**values) (the defaults with some replaced), frame_index(name);
// - one function per kernel of eom/model/kernels.hpp's catalog that the Kernels type has (detected with
//   the HasX concepts), taking float64 arrays: one state as 1-D arrays ((nq,), (nv,), ...), or a
//   batch along a leading axis ((n, nq), ...), where any argument may instead be one 1-D state
//   shared by every row; the loop runs in C++ with the GIL released, on threads for large batches
//   (set_num_threads). Results are new arrays; matrices come back as (rows, cols) C-ordered arrays
//   (the kernel's column-major output transposed), with a leading n for a batch.
//   Argument order: the state first, then u and p (None: zeros and the defaults), then t (a number,
//   or (n,) for a batch); the frame kernels take the frame (index or name) first.
// - bool kernels (forward_dynamics, its derivatives, taylor_coefficients, ...) never raise on a
//   numerical failure: like the C++ kernel, the failed state's outputs are NaN; with status=True
//   they also return the kernel's result (a bool for one state, a bool array for a batch).
// - integrate(t0, t1, x0, ...) through eom::integrate and ensemble(t0, t1, x0s, ...) through
//   eom::ensemble (threads), for models with the dynamics kernels (eom::Dynamics); arguments
//   eom::integrate refuses (Status::invalid_argument) raise ValueError with its reason (the
//   result's message).
//
// Bad arguments raise ValueError naming the kernel, the argument, the expected and the given
// shape or dtype (IndexError for a frame index out of range). Arrays of another dtype that NumPy
// casts safely to float64 (integers, float32) and non-contiguous or misaligned arrays are copied
// first; nothing is ever read with the wrong layout.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <type_traits>
#include <vector>

#include "eom/ensemble/ensemble.hpp"
#include "eom/integration/integrate.hpp"
#include "eom/model/kernels.hpp"

namespace eom::python {

namespace py = pybind11;
using index = py::ssize_t;

// ---- Settings (one per extension module: this header's inline variables are hidden in each) ----

// Threads for batches and ensembles: 0 = one per hardware thread.
inline std::atomic<unsigned> thread_setting{0};
// Whether batched forward_dynamics goes through forward_dynamics_batch where the model has it.
inline std::atomic<bool> batch_kernel_setting{true};

inline unsigned thread_count() noexcept {
  // hardware_concurrency() reads /sys on every call (microseconds): once is enough.
  static const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const unsigned n = thread_setting.load(std::memory_order_relaxed);
  return n != 0 ? n : hardware;
}

// Rows per thread at least: below this a thread costs more than it saves.
inline constexpr index grain = 1024;

// fn(begin, end) over [0, n) in contiguous chunks, one per thread (the caller's included).
template <class Fn> void parallel_for(index n, index min_rows, Fn&& fn) {
  min_rows = std::max<index>(min_rows, 1);
  if (n < 2 * min_rows) {
    fn(index{0}, n);
    return;
  }
  const index chunks =
      std::max<index>(1, std::min<index>(static_cast<index>(thread_count()), n / min_rows));
  if (chunks <= 1) {
    fn(index{0}, n);
    return;
  }
  const auto bound = [&](index c) { return n * c / chunks; };
  index done = 1;  // chunk 0 is the caller's
  {
    std::vector<std::jthread> pool;
    try {
      pool.reserve(static_cast<std::size_t>(chunks - 1));
      for (index c = 1; c < chunks; ++c, ++done) pool.emplace_back([&fn, b = bound(c), e = bound(c + 1)] { fn(b, e); });
    } catch (...) {  // no more threads: the caller does the rest
    }
    fn(bound(0), bound(1));
    if (done < chunks) fn(bound(done), n);
  }  // joined here
}

// ---- Status names ----

inline const char* status_name(Status s) noexcept {
  switch (s) {
    case Status::ok: return "ok";
    case Status::singular_dynamics: return "singular_dynamics";
    case Status::non_finite_state: return "non_finite_state";
    case Status::invalid_argument: return "invalid_argument";
    case Status::inconsistent_initial_state: return "inconsistent_initial_state";
    case Status::projection_failed: return "projection_failed";
    case Status::step_size_underflow: return "step_size_underflow";
    case Status::step_limit: return "step_limit";
    case Status::nonlinear_solve_failed: return "nonlinear_solve_failed";
    case Status::method_unavailable: return "method_unavailable";
    case Status::event_not_finite: return "event_not_finite";
    case Status::event_reset_failed: return "event_reset_failed";
    case Status::event_chattering: return "event_chattering";
  }
  return "unknown";
}

// ---- Arguments ----

inline std::string shape_text(const index* dims, index ndim) {
  std::string s = "(";
  for (index i = 0; i < ndim; ++i) {
    if (i > 0) s += ", ";
    s += std::to_string(dims[i]);
  }
  return s + (ndim == 1 ? ",)" : ")");
}

inline std::string expected_text(index size, bool rows) {
  // (appended piece by piece: GCC 12's -Wrestrict misfires on "literal" + std::string chains)
  const std::string n = std::to_string(size);
  std::string s = "(";
  s.append(n).append(",)");
  if (rows) s.append(" or (n, ").append(n).append(")");
  return s;
}

[[noreturn]] inline void fail(const std::string& kernel, const char* name, const std::string& what) {
  throw py::value_error(kernel + ": " + name + ": " + what);
}
[[noreturn]] inline void fail(const char* kernel, const char* name, const std::string& what) {
  fail(std::string(kernel), name, what);
}

// obj as a C-contiguous, aligned, native float64 array: itself when it is one, else a copy (safe
// casts only: integers, float32, ...). Anything else is a ValueError naming the argument.
inline py::array float64_array(const char* kernel, const char* name, py::handle obj) {
  constexpr char native = std::endian::native == std::endian::little ? '<' : '>';
  py::array a;
  if (py::detail::npy_api::get().PyArray_Check_(obj.ptr())) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else {
    a = py::array::ensure(obj);  // lists, tuples, numbers
    if (!a)
      fail(kernel, name,
           std::string("expected a float64 array, given ") + py::str(py::type::handle_of(obj).attr("__name__")).cast<std::string>());
  }
  const auto* array = py::detail::array_proxy(a.ptr());
  const auto* descr = py::detail::array_descriptor_proxy(array->descr);
  const char order = descr->byteorder;
  const bool is_double = descr->type_num == py::detail::npy_api::NPY_DOUBLE_ &&
                         (order == '=' || order == '|' || order == native);
  constexpr int contiguous = py::detail::npy_api::NPY_ARRAY_C_CONTIGUOUS_ | py::detail::npy_api::NPY_ARRAY_ALIGNED_;
  if (is_double && (array->flags & contiguous) == contiguous) return a;
  if (!is_double) {
    const py::dtype dt = a.dtype();
    static py::object can_cast = py::module_::import("numpy").attr("can_cast");
    static py::object float64 = py::module_::import("numpy").attr("float64");
    if (!can_cast(dt, float64, "safe").cast<bool>())
      fail(kernel, name, "expected float64 values, given " + std::string(py::str(static_cast<const py::handle&>(dt))));
  }
  auto copy = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!copy) throw py::error_already_set();
  return copy;
}

// A new, uninitialized C-ordered array of nd dimensions (float64, or bool).
inline py::array new_array(int nd, const index* dims, bool boolean = false) {
  auto& api = py::detail::npy_api::get();
  static PyObject* const float64 = api.PyArray_DescrFromType_(py::detail::npy_api::NPY_DOUBLE_);
  static PyObject* const flag = api.PyArray_DescrFromType_(py::detail::npy_api::NPY_BOOL_);
  PyObject* descr = boolean ? flag : float64;
  Py_INCREF(descr);  // PyArray_NewFromDescr steals it
  PyObject* a = api.PyArray_NewFromDescr_(api.PyArray_Type_, descr, nd, dims, nullptr, nullptr, 0, nullptr);
  if (a == nullptr) throw py::error_already_set();
  return py::reinterpret_steal<py::array>(a);
}

// One input after conversion: `size` doubles per state, one state shared by every row (rows < 0)
// or one per row.
struct Input {
  py::object hold;  // keeps the array (or its copy) alive
  const double* data = nullptr;
  index rows = -1;
  index size = 0;
  const double* row(index i) const noexcept { return rows < 0 ? data : data + i * size; }
};

// The arguments and results of one call: converts the inputs, finds the rows, makes the outputs,
// runs the kernel over the rows (GIL released) and returns the results.
class Call {
 public:
  static constexpr int max_outputs = 6;  // contact_dynamics_derivatives' six
  explicit Call(const char* kernel) noexcept : kernel_(kernel) {}

  // (size,) shared, or (n, size) when rows are allowed. None: `fallback` (size doubles), refused
  // when there is none.
  Input input(const char* name, py::handle obj, index size, const double* fallback = nullptr,
              bool allow_rows = true) {
    Input in;
    in.size = size;
    if (obj.is_none()) {
      if (fallback == nullptr && size > 0) fail(kernel_, name, "required, expected " + expected_text(size, allow_rows));
      in.data = size > 0 ? fallback : nullptr;
      return in;
    }
    py::array a = float64_array(kernel_, name, obj);
    const auto* array = py::detail::array_proxy(a.ptr());
    const index nd = array->nd, *shape = array->dimensions;
    if (!((nd == 1 && shape[0] == size) || (allow_rows && nd == 2 && shape[1] == size)))
      fail(kernel_, name, "expected shape " + expected_text(size, allow_rows) + ", given " + shape_text(shape, nd));
    if (nd == 2) rows_from(name, shape[0]), in.rows = shape[0];
    in.data = reinterpret_cast<const double*>(array->data);
    in.hold = std::move(a);
    return in;
  }

  // t: a number, or (n,) times, one per row.
  Input time(py::handle obj) {
    Input in;
    in.size = 1;
    if (PyFloat_Check(obj.ptr()) || PyLong_Check(obj.ptr())) {
      t_ = obj.cast<double>();
      in.data = &t_;
      return in;
    }
    py::array a = float64_array(kernel_, "t", obj);
    if (a.ndim() == 0) {
      t_ = *static_cast<const double*>(a.data());
      in.data = &t_;
      return in;
    }
    if (a.ndim() != 1) fail(kernel_, "t", "expected a number or shape (n,), given " + shape_text(a.shape(), a.ndim()));
    rows_from("t", a.shape(0));
    in.rows = a.shape(0);
    in.data = static_cast<const double*>(a.data());
    in.hold = std::move(a);
    return in;
  }

  bool batch() const noexcept { return rows_ >= 0; }
  index rows() const noexcept { return rows_ < 0 ? 1 : rows_; }

  // Outputs, declared after every input: a vector (size), a matrix (rows × cols, the kernel writes
  // it column-major), a scalar (a float for one state).
  int vector(index size) { return add({size}, false); }
  int matrix(index r, index c) { return add({r, c}, true); }
  int vectors(index count, index size) { return add({count, size}, false); }  // row-major as written
  int scalar() { return add({}, false); }

  // fn(i, outs) computes row i into outs[k] (output k, in the kernel's layout) and returns its
  // success; over every row, with the GIL released.
  template <class Fn> void run(Fn&& fn) {
    allocate();
    index scratch = 0;
    std::array<index, max_outputs> offset{};
    for (int k = 0; k < count_; ++k)
      if (out_[k].matrix) offset[k] = scratch, scratch += out_[k].size;
    // A batch runs without the GIL (other Python threads go on); one state is too short to bother.
    std::optional<py::gil_scoped_release> release;
    if (batch()) release.emplace();
    parallel_for(rows(), grain, [&](index begin, index end) {
      std::array<double, 256> small;
      std::vector<double> large(scratch > 256 ? static_cast<std::size_t>(scratch) : 0);
      double* buffer = scratch > 256 ? large.data() : small.data();
      std::array<double*, max_outputs> outs{};
      for (index i = begin; i < end; ++i) {
        for (int k = 0; k < count_; ++k) outs[k] = out_[k].matrix ? buffer + offset[k] : out_[k].data + i * out_[k].size;
        ok_[i] = static_cast<bool>(fn(i, outs.data()));
        for (int k = 0; k < count_; ++k)
          if (out_[k].matrix) transpose(k, outs[k], out_[k].data + i * out_[k].size);
      }
    });
  }

  // After run(): the outputs (one, or a tuple), and with `status` the kernel's result.
  py::object result(bool status = false) {
    const auto value = [&](int k) -> py::object {
      if (out_[k].ndim == 0 && !batch()) return py::float_(out_[k].data[0]);
      return out_[k].array;
    };
    if (count_ == 1 && !status) return value(0);
    py::tuple t(count_ + (status ? 1 : 0));
    for (int k = 0; k < count_; ++k) t[k] = value(k);
    if (status) t[count_] = batch() ? ok_array_ : py::object(py::bool_(ok_[0]));
    return t;
  }

  bool* ok() noexcept { return ok_; }
  double* out(int k) noexcept { return out_[k].data; }
  void allocate() {
    if (allocated_) return;
    allocated_ = true;
    for (int k = 0; k < count_; ++k) {
      Output& o = out_[k];
      if (o.ndim == 0 && !batch()) {  // a float: no array
        o.data = &o.scalar;
        continue;
      }
      std::array<index, 3> shape{};
      int nd = 0;
      if (batch()) shape[nd++] = rows_;
      for (int d = 0; d < o.ndim; ++d) shape[nd++] = o.dims[d];
      py::array a = new_array(nd, shape.data());
      o.data = static_cast<double*>(a.mutable_data());
      o.array = std::move(a);
    }
    if (batch()) {
      py::array ok = new_array(1, &rows_, true);
      ok_ = static_cast<bool*>(ok.mutable_data());
      ok_array_ = std::move(ok);
    } else {
      ok_ = &ok_one_;
    }
  }

 private:
  struct Output {
    std::array<index, 2> dims{};
    int ndim = 0;
    double scalar = 0;  // a scalar output of one state
    bool matrix = false;
    index size = 1;
    py::object array;  // (a default py::array_t would make a NumPy array of its own)
    double* data = nullptr;
  };

  void rows_from(const char* name, index n) {
    if (rows_ >= 0 && n != rows_)
      fail(kernel_, name, "has " + std::to_string(n) + " rows, but " + std::string(rows_name_) + " has " +
                              std::to_string(rows_));
    rows_ = n;
    rows_name_ = name;
  }

  int add(std::initializer_list<index> dims, bool matrix) {
    if (count_ == max_outputs)  // a binding's mistake, not the caller's: say which
      throw std::logic_error(std::string(kernel_) + ": more than Call::max_outputs outputs");
    Output& o = out_[count_];
    o.size = 1;
    o.ndim = 0;
    for (index d : dims) o.size *= d, o.dims[o.ndim++] = d;
    o.matrix = matrix;
    return count_++;
  }

  void transpose(int k, const double* column_major, double* row_major) const noexcept {
    const index r = out_[k].dims[0], c = out_[k].dims[1];
    for (index i = 0; i < r; ++i)
      for (index j = 0; j < c; ++j) row_major[i * c + j] = column_major[i + r * j];
  }

  const char* kernel_;
  index rows_ = -1;
  const char* rows_name_ = "";
  double t_ = 0;
  std::array<Output, max_outputs> out_{};
  int count_ = 0;
  bool allocated_ = false;
  py::object ok_array_;
  bool ok_one_ = false;
  bool* ok_ = nullptr;
};

// ---- The model ----

// The kernels this header binds; adding a row to EOM_KERNEL_CATALOG without a binding here stops
// the build of every Python module (bound_kernel below), so none is silently left out.
inline constexpr auto bound_kernels = std::to_array<std::string_view>({
    "mass_matrix", "mass_matrix_dot", "coriolis", "potential_gradient", "generalized_forces",
    "constraint_residual", "constraint_jacobian", "constraint_bias", "forward_dynamics",
    "kinetic_energy", "potential_energy", "forward_dynamics_derivatives", "inverse_dynamics",
    "taylor_coefficients", "forward_dynamics_parameter_derivatives",
    "forward_dynamics_batch",  // used by forward_dynamics for batches, not a function of its own
    "frame_placement", "frame_jacobian", "frame_acceleration_bias", "center_of_mass",
    "center_of_mass_jacobian", "centroidal_momentum_matrix", "inverse_dynamics_derivatives",
    "contact_dynamics", "impulse_dynamics", "contact_dynamics_derivatives",
    "impulse_dynamics_derivatives"});

constexpr bool bound_kernel(std::string_view name) {
  return std::find(bound_kernels.begin(), bound_kernels.end(), name) != bound_kernels.end();
}
#define EOM_PYTHON_CHECK_BOUND(name, ...)                                                          \
  static_assert(bound_kernel(#name), "python/eom_python.hpp: the kernel `" #name                  \
                                     "` of EOM_KERNEL_CATALOG has no Python binding; add one");
EOM_KERNEL_CATALOG(EOM_PYTHON_CHECK_BOUND)
#undef EOM_PYTHON_CHECK_BOUND

inline Method parse_method(const std::string& name) {
  for (Method m : {Method::rk4, Method::dopri5, Method::dop853, Method::radau5, Method::taylor,
                   Method::taylor_paper, Method::variational})
    if (name == to_string(m)) return m;
  throw py::value_error("method: unknown method '" + name +
                        "'; the methods are rk4, dopri5, dop853, radau5, taylor, taylor_paper, variational");
}

inline Stabilization parse_stabilization(const std::string& name) {
  Stabilization s;
  if (name == "none") s.method = Stabilization::Method::none;
  else if (name == "baumgarte") s.method = Stabilization::Method::baumgarte;
  else if (name == "projection") s.method = Stabilization::Method::projection;
  else throw py::value_error("stabilization: unknown '" + name + "'; expected none, baumgarte or projection");
  return s;
}

template <class K> struct Model {
  static constexpr int nq = K::nq, nv = nv_of<K>, nu = K::nu, np = K::np, nc = K::nc;
  static constexpr int nframes = [] {
    if constexpr (requires { K::nframes; }) return static_cast<int>(K::nframes);
    else return 0;
  }();
  static constexpr int ncontact_sets = [] {
    if constexpr (requires { K::ncontact_sets; }) return static_cast<int>(K::ncontact_sets);
    else return 0;
  }();
  static constexpr int state_size = nq + nv;

  static const double* parameters() noexcept {
    if constexpr (np > 0) return K::parameter_values.data();
    else return nullptr;
  }
  static const double* zero_inputs() noexcept {
    static constexpr std::array<double, (nu > 0 ? nu : 1)> zeros{};
    return zeros.data();
  }
  static Input p(Call& c, py::handle obj) { return c.input("p", obj, np, parameters()); }
  static Input u(Call& c, py::handle obj) { return c.input("u", obj, nu, zero_inputs()); }

  // A contact set by index or name (CONTACTS), with its rows.
  static std::pair<int, int> contact_set(const char* kernel, py::handle s) {
    if constexpr (ncontact_sets > 0) {
      if (py::isinstance<py::str>(s)) {
        const std::string name = s.cast<std::string>();
        std::string names;
        for (int i = 0; i < ncontact_sets; ++i) {
          if (K::contact_set_names[i] == name) return {i, K::contact_rows[i]};
          names += (i ? ", " : "") + std::string(K::contact_set_names[i]);
        }
        throw py::value_error(std::string(kernel) + ": contact_set: unknown set '" + name + "'; the sets are: " + names);
      }
      if (!PyLong_Check(s.ptr())) fail(kernel, "contact_set", "expected a contact set's index or name");
      const long i = s.cast<long>();
      if (i < 0 || i >= ncontact_sets)
        throw py::index_error(std::string(kernel) + ": contact_set: index " + std::to_string(i) +
                              " out of range [0, " + std::to_string(ncontact_sets) + ")");
      return {static_cast<int>(i), K::contact_rows[i]};
    }
    (void)s;
    throw py::value_error(std::string(kernel) + ": the model has no contact sets (CONTACTS)");
  }

  static int frame(const char* kernel, py::handle f) {
    if (py::isinstance<py::str>(f)) {
      const std::string name = f.cast<std::string>();
      if constexpr (nframes > 0)
        for (int i = 0; i < nframes; ++i)
          if (K::frame_names[i] == name) return i;
      std::string names;
      if constexpr (nframes > 0)
        for (auto n : K::frame_names) names += (names.empty() ? "" : ", ") + std::string(n);
      throw py::value_error(std::string(kernel) + ": frame: unknown frame '" + name + "'; the frames are: " + names);
    }
    if (!PyLong_Check(f.ptr())) fail(kernel, "frame", "expected a frame index or name");
    const long i = f.cast<long>();
    if (i < 0 || i >= nframes)
      throw py::index_error(std::string(kernel) + ": frame: index " + std::to_string(i) + " out of range [0, " +
                            std::to_string(nframes) + ")");
    return static_cast<int>(i);
  }
};

// A read-only float64 array holding `values` (a std::array of double).
template <class Values> py::array_t<double> constant_array(const Values& values) {
  py::array_t<double> a(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), a.mutable_data());
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

template <class Names> py::tuple name_tuple(const Names& names) {
  py::tuple t(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) t[i] = py::str(std::string(names[i]));
  return t;
}

// forward_dynamics over a batch, K::batch_lanes rows per call of forward_dynamics_batch (each lane
// bitwise the scalar kernel's result, docs/CONTRACT.md §3); the rows left over go one by one.
template <class K>
void forward_dynamics_lanes(Call& c, const Input& T, const Input& Q, const Input& QD, const Input& U,
                            const Input& P) {
  constexpr int W = K::batch_lanes, nq = K::nq, nv = Model<K>::nv, nu = K::nu, np = K::np;
  c.allocate();
  double* qdd = c.out(0);
  bool* ok = c.ok();
  const index n = c.rows(), groups = n / W;
  py::gil_scoped_release release;
  parallel_for(groups, grain / W, [&](index g0, index g1) {
    std::array<double, W> t;
    std::array<double, nq * W> q;  // q: nq rows; qd and qdd: nv (quaternions: nv < nq)
    std::array<double, nv * W> qd, a;
    std::array<double, (nu > 0 ? nu : 1) * W> u{};
    std::array<double, (np > 0 ? np : 1) * W> p{};
    const auto gather = [&](const Input& in, index first, int size, double* soa) {
      for (int l = 0; l < W; ++l) {
        const double* row = in.row(first + l);
        for (int j = 0; j < size; ++j) soa[j * W + l] = row[j];
      }
    };
    if (U.rows < 0 && nu > 0) gather(U, 0, nu, u.data());
    if (P.rows < 0 && np > 0) gather(P, 0, np, p.data());
    for (index g = g0; g < g1; ++g) {
      const index first = g * W;
      gather(T, first, 1, t.data());
      gather(Q, first, nq, q.data());
      gather(QD, first, nv, qd.data());
      if (U.rows >= 0 && nu > 0) gather(U, first, nu, u.data());
      if (P.rows >= 0 && np > 0) gather(P, first, np, p.data());
      const unsigned mask = K::forward_dynamics_batch(t.data(), q.data(), qd.data(), nu > 0 ? u.data() : nullptr,
                                                      np > 0 ? p.data() : nullptr, a.data());
      for (int l = 0; l < W; ++l) {
        double* row = qdd + (first + l) * nv;
        for (int j = 0; j < nv; ++j) row[j] = a[j * W + l];
        ok[first + l] = ((mask >> l) & 1u) != 0;
      }
    }
  });
  for (index i = groups * W; i < n; ++i)
    ok[i] = K::forward_dynamics(*T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), qdd + i * nv);
}

template <class K> void bind_model(py::module_& m, const char* name) {
  using M = Model<K>;
  constexpr int nq = M::nq, nv = M::nv, nu = M::nu, np = M::np, nc = M::nc;
  using namespace py::literals;
  const auto none = py::none();

  m.doc() = std::string("Equations of motion of the model ") + name +
            ", generated by eomgen (docs/CONTRACT.md; python/README.md).";
  m.attr("name") = name;
  m.attr("nq") = nq;
  m.attr("nv") = nv;
  m.attr("nu") = nu;
  m.attr("np") = np;
  m.attr("nc") = nc;
  m.attr("nframes") = M::nframes;
  m.attr("state_size") = M::state_size;
  m.attr("floating_base") = nv != nq;  // quaternions in q: a free joint's, ball joints'
  {
    const Layout layout = layout_of<K>();
    py::tuple at(layout.count());
    for (int k = 0; k < layout.count(); ++k) at[k] = layout.quaternions[k];
    m.attr("quaternions") = at;
  }
  m.attr("batch_lanes") = batch_lanes<K>;
  if constexpr (requires { K::taylor_max_order; }) m.attr("taylor_max_order") = static_cast<int>(K::taylor_max_order);
  if constexpr (np > 0) m.attr("parameter_names") = name_tuple(K::parameter_names);
  else m.attr("parameter_names") = py::tuple();
  {
    py::array_t<double> values(np);
    for (int i = 0; i < np; ++i) values.mutable_data()[i] = M::parameters()[i];
    values.attr("setflags")("write"_a = false);
    m.attr("parameter_values") = values;
  }
  if constexpr (M::nframes > 0) m.attr("frame_names") = name_tuple(K::frame_names);
  else m.attr("frame_names") = py::tuple();
  m.attr("ncontact_sets") = M::ncontact_sets;
  if constexpr (M::ncontact_sets > 0) {
    m.attr("contact_set_names") = name_tuple(K::contact_set_names);
    py::tuple rows(M::ncontact_sets);
    for (int i = 0; i < M::ncontact_sets; ++i) rows[i] = K::contact_rows[i];
    m.attr("contact_rows") = rows;
  } else {
    m.attr("contact_set_names") = py::tuple();
    m.attr("contact_rows") = py::tuple();
  }
  // The names and limits of the generated header (docs/CONTRACT.md §3): tuples of str and
  // read-only float64 arrays (±inf where the model gives no limit).
  if constexpr (requires { K::coordinate_names; }) m.attr("coordinate_names") = name_tuple(K::coordinate_names);
  if constexpr (requires { K::velocity_names; }) m.attr("velocity_names") = name_tuple(K::velocity_names);
  if constexpr (requires { K::input_names; }) m.attr("input_names") = name_tuple(K::input_names);
  if constexpr (requires { K::position_lower; }) m.attr("position_lower") = constant_array(K::position_lower);
  if constexpr (requires { K::position_upper; }) m.attr("position_upper") = constant_array(K::position_upper);
  if constexpr (requires { K::effort_limit; }) m.attr("effort_limit") = constant_array(K::effort_limit);
  if constexpr (requires { K::velocity_limit; }) m.attr("velocity_limit") = constant_array(K::velocity_limit);
  {
    py::list kernels;
#define EOM_PYTHON_KERNEL_NAME(kname, Concept, ...) \
  if constexpr (Has##Concept<K>) kernels.append(#kname);
    EOM_KERNEL_CATALOG(EOM_PYTHON_KERNEL_NAME)
#undef EOM_PYTHON_KERNEL_NAME
    m.attr("kernels") = py::tuple(kernels);
  }

  m.def("parameters", [](py::kwargs values) {
    py::array_t<double> p(np);
    for (int i = 0; i < np; ++i) p.mutable_data()[i] = M::parameters()[i];
    for (auto [key, value] : values) {
      const std::string k = py::str(key);
      int i = 0;
      if constexpr (np > 0)
        while (i < np && K::parameter_names[i] != k) ++i;
      if (i == np) throw py::value_error("parameters: unknown parameter '" + k + "'");
      p.mutable_data()[i] = py::cast<double>(value);
    }
    return p;
  }, "The default parameter values as a new array, those named replaced: parameters(g=0.0).");
  m.def("frame_index", [](py::handle f) { return M::frame("frame_index", f); }, "frame"_a,
        "The index of a frame (by name; an index is checked and returned).");
  m.def("set_num_threads", [](unsigned n) { thread_setting = n; }, "threads"_a,
        "Threads for batches (rows >= 2048) and ensembles; 0 (the default): one per hardware thread.");
  m.def("get_num_threads", [] { return thread_count(); });
  m.def("set_batch_kernel", [](bool on) { batch_kernel_setting = on; }, "enabled"_a,
        "Whether batched forward_dynamics uses forward_dynamics_batch where the model has it "
        "(default True; the results are bitwise the same).");

  // ---- Kernels ----
  if constexpr (HasMassMatrix<K>)
    m.def("mass_matrix", [](py::handle q, py::handle p) {
      Call c("mass_matrix");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.matrix(nv, nv);
      c.run([&](index i, double** out) { return K::mass_matrix(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "M (nv, nv), or (n, nv, nv).");
  if constexpr (HasMassMatrixDot<K>)
    m.def("mass_matrix_dot", [](py::handle q, py::handle qd, py::handle p) {
      Call c("mass_matrix_dot");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.matrix(nv, nv);
      c.run([&](index i, double** out) { return K::mass_matrix_dot(Q.row(i), QD.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "qd"_a, "p"_a = none, "dM/dt (nv, nv), or (n, nv, nv).");
  if constexpr (HasCoriolis<K>)
    m.def("coriolis", [](py::handle q, py::handle qd, py::handle p) {
      Call c("coriolis");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.vector(nv);
      c.run([&](index i, double** out) { return K::coriolis(Q.row(i), QD.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "qd"_a, "p"_a = none, "The velocity-product terms c (nv,), or (n, nv).");
  if constexpr (HasPotentialGradient<K>)
    m.def("potential_gradient", [](py::handle q, py::handle p) {
      Call c("potential_gradient");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.vector(nv);
      c.run([&](index i, double** out) { return K::potential_gradient(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "dV/dq (nv,), or (n, nv).");
  if constexpr (HasGeneralizedForces<K>)
    m.def("generalized_forces", [](py::handle q, py::handle qd, py::handle u, py::handle p, py::handle t) {
      Call c("generalized_forces");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.vector(nv);
      c.run([&](index i, double** out) {
        return K::generalized_forces(*T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), out[0]), true;
      });
      return c.result();
    }, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "Q (nv,), or (n, nv).");
  if constexpr (HasConstraintResidual<K>)
    m.def("constraint_residual", [](py::handle q, py::handle p) {
      Call c("constraint_residual");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.vector(nc);
      c.run([&](index i, double** out) { return K::constraint_residual(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "phi (nc,), or (n, nc).");
  if constexpr (HasConstraintJacobian<K>)
    m.def("constraint_jacobian", [](py::handle q, py::handle p) {
      Call c("constraint_jacobian");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.matrix(nc, nv);
      c.run([&](index i, double** out) { return K::constraint_jacobian(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "C (nc, nv), or (n, nc, nv).");
  if constexpr (HasConstraintBias<K>)
    m.def("constraint_bias", [](py::handle q, py::handle qd, py::handle p) {
      Call c("constraint_bias");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.vector(nc);
      c.run([&](index i, double** out) { return K::constraint_bias(Q.row(i), QD.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "qd"_a, "p"_a = none, "gamma (nc,), or (n, nc).");
  if constexpr (HasForwardDynamics<K>)
    m.def("forward_dynamics", [](py::handle q, py::handle qd, py::handle u, py::handle p, py::handle t, bool status) {
      Call c("forward_dynamics");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.vector(nv);
      if constexpr (HasForwardDynamicsBatch<K>) {
        if (c.batch() && c.rows() >= K::batch_lanes && batch_kernel_setting.load(std::memory_order_relaxed)) {
          forward_dynamics_lanes<K>(c, T, Q, QD, U, P);
          return c.result(status);
        }
      }
      c.run([&](index i, double** out) {
        return K::forward_dynamics(*T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), out[0]);
      });
      return c.result(status);
    }, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "status"_a = false,
       "The accelerations qdd (nv,), or (n, nv); NaN where the kernel fails (status=True: also "
       "its result).");
  if constexpr (HasKineticEnergy<K>)
    m.def("kinetic_energy", [](py::handle q, py::handle qd, py::handle p) {
      Call c("kinetic_energy");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.scalar();
      c.run([&](index i, double** out) { return out[0][0] = K::kinetic_energy(Q.row(i), QD.row(i), P.row(i)), true; });
      return c.result();
    }, "q"_a, "qd"_a, "p"_a = none, "T: a float, or (n,).");
  if constexpr (HasPotentialEnergy<K>)
    m.def("potential_energy", [](py::handle q, py::handle p) {
      Call c("potential_energy");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.scalar();
      c.run([&](index i, double** out) { return out[0][0] = K::potential_energy(Q.row(i), P.row(i)), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "V: a float, or (n,).");
  if constexpr (HasForwardDynamicsDerivatives<K>)
    m.def("forward_dynamics_derivatives", [](py::handle q, py::handle qd, py::handle u, py::handle p, py::handle t,
                                             bool status) {
      Call c("forward_dynamics_derivatives");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.matrix(nv, nv);
      c.matrix(nv, nv);
      c.matrix(nv, nu);
      c.run([&](index i, double** out) {
        return K::forward_dynamics_derivatives(*T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), out[0], out[1],
                                               out[2]);
      });
      return c.result(status);
    }, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "status"_a = false,
       "(dqdd/dq (nv, nv), dqdd/dqd (nv, nv), dqdd/du (nv, nu)), each with a leading n for a batch.");
  if constexpr (HasInverseDynamics<K>)
    m.def("inverse_dynamics", [](py::handle q, py::handle qd, py::handle qdd, py::handle u, py::handle p,
                                 py::handle t) {
      Call c("inverse_dynamics");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto QDD = c.input("qdd", qdd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.vector(nv);
      c.run([&](index i, double** out) {
        return K::inverse_dynamics(*T.row(i), Q.row(i), QD.row(i), QDD.row(i), U.row(i), P.row(i), out[0]), true;
      });
      return c.result();
    }, "q"_a, "qd"_a, "qdd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "tau (nv,), or (n, nv).");
  if constexpr (HasTaylorCoefficients<K>)
    m.def("taylor_coefficients", [](int order, py::handle q, py::handle qd, py::handle u, py::handle p, py::handle t,
                                    bool status) {
      if (order < 1 || order > K::taylor_max_order)
        throw py::value_error("taylor_coefficients: order: expected 1 ... " + std::to_string(K::taylor_max_order) +
                              ", given " + std::to_string(order));
      Call c("taylor_coefficients");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.vectors(order + 1, nq);
      c.vectors(order + 1, nv);
      const std::size_t work = static_cast<std::size_t>(K::taylor_workspace) * static_cast<std::size_t>(order + 1);
      c.run([&](index i, double** out) {
        thread_local std::vector<double> w;
        if (w.size() < work) w.resize(work);
        return K::taylor_coefficients(order, *T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), out[0], out[1],
                                      w.data());
      });
      return c.result(status);
    }, "order"_a, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "status"_a = false,
       "(q_k (order + 1, nq), qd_k (order + 1, nv)): the normalized derivatives x^(k)(t)/k!, "
       "k = 0 ... order; with a leading n for a batch.");
  if constexpr (HasForwardDynamicsParameterDerivatives<K>)
    m.def("forward_dynamics_parameter_derivatives", [](py::handle q, py::handle qd, py::handle u, py::handle p,
                                                       py::handle t, bool status) {
      Call c("forward_dynamics_parameter_derivatives");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.matrix(nv, np);
      c.run([&](index i, double** out) {
        return K::forward_dynamics_parameter_derivatives(*T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), out[0]);
      });
      return c.result(status);
    }, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "status"_a = false,
       "dqdd/dp (nv, np), or (n, nv, np).");
  if constexpr (HasFramePlacement<K>)
    m.def("frame_placement", [](py::handle frame, py::handle q, py::handle p) {
      const int f = M::frame("frame_placement", frame);
      Call c("frame_placement");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.vector(3);
      c.matrix(3, 3);
      c.run([&](index i, double** out) { return K::frame_placement(f, Q.row(i), P.row(i), out[0], out[1]), true; });
      return c.result();
    }, "frame"_a, "q"_a, "p"_a = none,
       "(position (3,), rotation (3, 3): frame axes to world), with a leading n for a batch.");
  if constexpr (HasFrameJacobian<K>)
    m.def("frame_jacobian", [](py::handle frame, py::handle q, py::handle p) {
      const int f = M::frame("frame_jacobian", frame);
      Call c("frame_jacobian");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.matrix(6, nv);
      c.run([&](index i, double** out) { return K::frame_jacobian(f, Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "frame"_a, "q"_a, "p"_a = none,
       "J (6, nv): rows 0-2 the origin's velocity, 3-5 the angular velocity, world axes; or (n, 6, nv).");
  if constexpr (HasFrameAccelerationBias<K>)
    m.def("frame_acceleration_bias", [](py::handle frame, py::handle q, py::handle qd, py::handle p) {
      const int f = M::frame("frame_acceleration_bias", frame);
      Call c("frame_acceleration_bias");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.vector(6);
      c.run([&](index i, double** out) {
        return K::frame_acceleration_bias(f, Q.row(i), QD.row(i), P.row(i), out[0]), true;
      });
      return c.result();
    }, "frame"_a, "q"_a, "qd"_a, "p"_a = none, "J̇v (6,), or (n, 6).");
  if constexpr (HasCenterOfMass<K>)
    m.def("center_of_mass", [](py::handle q, py::handle p) {
      Call c("center_of_mass");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.vector(3);
      c.run([&](index i, double** out) { return K::center_of_mass(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "The mass centre (3,), or (n, 3).");
  if constexpr (HasCenterOfMassJacobian<K>)
    m.def("center_of_mass_jacobian", [](py::handle q, py::handle p) {
      Call c("center_of_mass_jacobian");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.matrix(3, nv);
      c.run([&](index i, double** out) { return K::center_of_mass_jacobian(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "dG/dq (3, nv), or (n, 3, nv).");
  if constexpr (HasCentroidalMomentumMatrix<K>)
    m.def("centroidal_momentum_matrix", [](py::handle q, py::handle p) {
      Call c("centroidal_momentum_matrix");
      auto Q = c.input("q", q, nq);
      auto P = M::p(c, p);
      c.matrix(6, nv);
      c.run([&](index i, double** out) { return K::centroidal_momentum_matrix(Q.row(i), P.row(i), out[0]), true; });
      return c.result();
    }, "q"_a, "p"_a = none, "A_G (6, nv), or (n, 6, nv).");

  if constexpr (HasInverseDynamicsDerivatives<K>)
    m.def("inverse_dynamics_derivatives", [](py::handle q, py::handle qd, py::handle qdd, py::handle u, py::handle p,
                                             py::handle t) {
      Call c("inverse_dynamics_derivatives");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto QDD = c.input("qdd", qdd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.matrix(nv, nv);
      c.matrix(nv, nv);
      c.run([&](index i, double** out) {
        return K::inverse_dynamics_derivatives(*T.row(i), Q.row(i), QD.row(i), QDD.row(i), U.row(i), P.row(i),
                                               out[0], out[1]),
               true;
      });
      return c.result();
    }, "q"_a, "qd"_a, "qdd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0,
       "(dtau/dq (nv, nv), dtau/dqd (nv, nv)) of inverse_dynamics, each with a leading n for a batch.");
  if constexpr (HasContactDynamics<K>)
    m.def("contact_dynamics", [](py::handle set, py::handle q, py::handle qd, py::handle u, py::handle p,
                                 py::handle t, double kd, double rho, bool status) {
      const auto [s, rows] = M::contact_set("contact_dynamics", set);
      Call c("contact_dynamics");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.vector(nv);
      c.vector(rows);
      c.run([&](index i, double** out) {
        return K::contact_dynamics(s, *T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), kd, rho, out[0], out[1]);
      });
      return c.result(status);
    }, "contact_set"_a, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "kd"_a = 0.0, "rho"_a = 0.0,
       "status"_a = false,
       "(vdot (nv,), lambda (contact_rows[s],)) on the contact set (index or name), each with a leading n "
       "for a batch; NaN where the kernel fails (kd < 0, rho < 0, a singular set with rho = 0).");
  if constexpr (HasImpulseDynamics<K>)
    m.def("impulse_dynamics", [](py::handle set, py::handle q, py::handle qd, py::handle p, double restitution,
                                 double rho, bool status) {
      const auto [s, rows] = M::contact_set("impulse_dynamics", set);
      Call c("impulse_dynamics");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.vector(nv);
      c.vector(rows);
      c.run([&](index i, double** out) {
        return K::impulse_dynamics(s, Q.row(i), QD.row(i), P.row(i), restitution, rho, out[0], out[1]);
      });
      return c.result(status);
    }, "contact_set"_a, "q"_a, "qd"_a, "p"_a = none, "restitution"_a = 0.0, "rho"_a = 0.0, "status"_a = false,
       "(v_plus (nv,), impulse (contact_rows[s],)) as the contact set (index or name) closes on the velocity "
       "qd, each with a leading n for a batch; NaN where the kernel fails.");
  if constexpr (HasContactDynamicsDerivatives<K>)
    m.def("contact_dynamics_derivatives", [](py::handle set, py::handle q, py::handle qd, py::handle u, py::handle p,
                                             py::handle t, double kd, double rho, bool status) {
      const auto [s, rows] = M::contact_set("contact_dynamics_derivatives", set);
      Call c("contact_dynamics_derivatives");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto U = M::u(c, u);
      auto P = M::p(c, p);
      auto T = c.time(t);
      c.matrix(nv, nv);
      c.matrix(nv, nv);
      c.matrix(nv, nu);
      c.matrix(rows, nv);
      c.matrix(rows, nv);
      c.matrix(rows, nu);
      c.run([&](index i, double** out) {
        return K::contact_dynamics_derivatives(s, *T.row(i), Q.row(i), QD.row(i), U.row(i), P.row(i), kd, rho,
                                               out[0], out[1], out[2], out[3], out[4], out[5]);
      });
      return c.result(status);
    }, "contact_set"_a, "q"_a, "qd"_a, "u"_a = none, "p"_a = none, "t"_a = 0.0, "kd"_a = 0.0, "rho"_a = 0.0,
       "status"_a = false,
       "(dvdot/dq, dvdot/dqd (nv, nv), dvdot/du (nv, nu), dlambda/dq, dlambda/dqd (rows, nv), dlambda/du "
       "(rows, nu)) of contact_dynamics, each with a leading n for a batch.");
  if constexpr (HasImpulseDynamicsDerivatives<K>)
    m.def("impulse_dynamics_derivatives", [](py::handle set, py::handle q, py::handle qd, py::handle p,
                                             double restitution, double rho, bool status) {
      const auto [s, rows] = M::contact_set("impulse_dynamics_derivatives", set);
      Call c("impulse_dynamics_derivatives");
      auto Q = c.input("q", q, nq);
      auto QD = c.input("qd", qd, nv);
      auto P = M::p(c, p);
      c.matrix(nv, nv);
      c.matrix(nv, nv);
      c.matrix(rows, nv);
      c.matrix(rows, nv);
      c.run([&](index i, double** out) {
        return K::impulse_dynamics_derivatives(s, Q.row(i), QD.row(i), P.row(i), restitution, rho, out[0], out[1],
                                               out[2], out[3]);
      });
      return c.result(status);
    }, "contact_set"_a, "q"_a, "qd"_a, "p"_a = none, "restitution"_a = 0.0, "rho"_a = 0.0, "status"_a = false,
       "(dv_plus/dq, dv_plus/dqd (nv, nv), dimpulse/dq, dimpulse/dqd (rows, nv)) of impulse_dynamics, each "
       "with a leading n for a batch.");

  // ---- Integration ----
  if constexpr (Dynamics<K>) {
    constexpr int m_state = M::state_size;
    m.def("integrate", [](double t0, double t1, py::handle x0, py::handle u, py::handle p, const std::string& method,
                          double rtol, double atol, double step, py::handle t_eval, long max_steps,
                          const std::string& stabilization) {
      Call c("integrate");
      auto X = c.input("x0", x0, m_state, nullptr, false);
      auto U = c.input("u", u, nu, M::zero_inputs(), false);
      auto P = c.input("p", p, np, M::parameters(), false);
      IntegrationOptions opt;
      opt.method = parse_method(method);
      opt.rtol = rtol, opt.atol = atol, opt.step = step, opt.max_steps = max_steps;
      opt.stabilization = parse_stabilization(stabilization);
      Input E;
      if (!t_eval.is_none()) {
        py::array a = float64_array("integrate", "t_eval", t_eval);
        if (a.ndim() != 1) fail("integrate", "t_eval", "expected shape (k,), given " + shape_text(a.shape(), a.ndim()));
        E.data = static_cast<const double*>(a.data());
        E.size = a.shape(0);
        E.hold = std::move(a);
        opt.output_times = std::span<const double>(E.data, static_cast<std::size_t>(E.size));
      }
      StateFor<K> x;
      std::copy(X.data, X.data + m_state, x.begin());
      std::vector<double> times, states;
      if (E.size > 0) times.reserve(static_cast<std::size_t>(E.size)), states.reserve(static_cast<std::size_t>(E.size * m_state));
      IntegrationResultFor<K> r;
      {
        py::gil_scoped_release release;
        r = eom::integrate<K>(t0, t1, x, nu > 0 ? U.data : nullptr, np > 0 ? P.data : nullptr, opt,
                              [&](double t, const StateFor<K>& y) {
                                times.push_back(t);
                                states.insert(states.end(), y.begin(), y.end());
                              });
      }
      if (r.status == Status::invalid_argument)  // a bad argument: ValueError naming it, as above
        throw py::value_error(std::string("integrate: ") +
                              (r.message ? r.message : "an argument was refused"));
      const index k = static_cast<index>(times.size());
      py::array_t<double> T(k), S({k, index{m_state}});
      std::copy(times.begin(), times.end(), T.mutable_data());
      std::copy(states.begin(), states.end(), S.mutable_data());
      return py::make_tuple(T, S, status_name(r.status));
    }, "t0"_a, "t1"_a, "x0"_a, "u"_a = none, "p"_a = none, "method"_a = "dop853", "rtol"_a = 1e-8,
       "atol"_a = 1e-10, "step"_a = 0.0, "t_eval"_a = none, "max_steps"_a = 1000000L, "stabilization"_a = "none",
       "Integrates x = [q, v] from t0 to t1 with eom::integrate: (times (k,), states (k, nq + nv), status), "
       "the states at t0 and after every step, or at exactly t_eval; status is 'ok' or the name of "
       "eom::Status that stopped it (the last row is then the last good state). u is held.");

    m.def("ensemble", [](double t0, double t1, py::handle x0, py::handle u, py::handle p, const std::string& method,
                         double rtol, double atol, double step, py::handle t_eval, long max_steps,
                         const std::string& stabilization, unsigned threads, bool lockstep) {
      Call c("ensemble");
      auto X = c.input("x0", x0, m_state);
      auto U = c.input("u", u, nu, M::zero_inputs());
      auto P = c.input("p", p, np, M::parameters());
      if (X.rows < 0) fail("ensemble", "x0", "expected shape (n, " + std::to_string(m_state) + "), given (" +
                                                 std::to_string(m_state) + ",)");
      const index n = X.rows;
      EnsembleOptions opt;
      opt.t0 = t0, opt.t1 = t1;
      opt.integration.method = parse_method(method);
      opt.integration.rtol = rtol, opt.integration.atol = atol, opt.integration.step = step;
      opt.integration.max_steps = max_steps;
      opt.integration.stabilization = parse_stabilization(stabilization);
      opt.threads = threads != 0 ? threads : thread_count();
      opt.lockstep = lockstep;
      std::vector<double> sample_times;
      if (t_eval.is_none()) {
        sample_times.push_back(t1);
      } else {
        py::array a = float64_array("ensemble", "t_eval", t_eval);
        if (a.ndim() != 1) fail("ensemble", "t_eval", "expected shape (k,), given " + shape_text(a.shape(), a.ndim()));
        const double* d = static_cast<const double*>(a.data());
        sample_times.assign(d, d + a.shape(0));
      }
      opt.sample_times = sample_times;
      const auto cases_x0 = std::span<const StateFor<K>>(reinterpret_cast<const StateFor<K>*>(X.data),
                                                          static_cast<std::size_t>(n));
      static_assert(sizeof(StateFor<K>) == sizeof(double) * m_state);
      EnsembleCasesFor<K> cases{cases_x0,
                                std::span<const double>(P.data, static_cast<std::size_t>(P.rows < 0 ? np : n * np)),
                                std::span<const double>(U.data, static_cast<std::size_t>(U.rows < 0 ? nu : n * nu))};
      const index k = static_cast<index>(sample_times.size());
      std::vector<IntegrationResultFor<K>> results(static_cast<std::size_t>(n));
      py::array_t<double> S({n, k, index{m_state}});
      auto samples = std::span<StateFor<K>>(reinterpret_cast<StateFor<K>*>(S.mutable_data()),
                                            static_cast<std::size_t>(n * k));
      Status s;
      {
        py::gil_scoped_release release;
        s = eom::ensemble<K>(cases, opt, std::span(results), samples);
      }
      if (s != Status::ok) {  // the sizes are checked above: what is left is t_eval
        std::string why = "the ensemble was refused (" + std::string(to_string(s)) + ")";
        double previous = t0;
        for (double t : sample_times) {
          if (!(std::isfinite(t) && t >= previous && t <= t1)) {
            why = "t_eval: must be finite, ascending and inside [t0, t1]";
            break;
          }
          previous = t;
        }
        throw py::value_error("ensemble: " + why);
      }
      // A case refused for its arguments: the shared ones (options, time span) raise ValueError
      // naming the argument and why, as integrate() does; a case's own x0 leaves that case
      // "invalid_argument" (the others run) with a RuntimeWarning saying why.
      std::string refused;
      index refused_cases = 0;
      for (std::size_t i = 0; i < results.size(); ++i)
        if (results[i].status == Status::invalid_argument) {
          const char* why = results[i].message;
          if (!why) why = integration_argument_problem<K>(t0, t1, cases_x0[i], opt.integration);
          const std::string reason = why ? why : "an argument was refused";
          if (reason.rfind("x0:", 0) != 0) throw py::value_error("ensemble: " + reason);
          if (refused_cases++ == 0) refused = "case " + std::to_string(i) + ": " + reason;
        }
      if (refused_cases > 0 &&
          PyErr_WarnEx(PyExc_RuntimeWarning,
                       ("ensemble: " + std::to_string(refused_cases) + " of " + std::to_string(n) +
                        " cases refused (status invalid_argument), the first " + refused).c_str(), 1) < 0)
        throw py::error_already_set();  // warnings turned into errors
      py::array_t<double> T(k);
      std::copy(sample_times.begin(), sample_times.end(), T.mutable_data());
      py::list status;
      for (const auto& r : results) status.append(status_name(r.status));
      return py::make_tuple(T, S, status);
    }, "t0"_a, "t1"_a, "x0"_a, "u"_a = none, "p"_a = none, "method"_a = "dop853", "rtol"_a = 1e-8,
       "atol"_a = 1e-10, "step"_a = 0.0, "t_eval"_a = none, "max_steps"_a = 1000000L, "stabilization"_a = "none",
       "threads"_a = 0u, "lockstep"_a = false,
       "Integrates n cases (x0 (n, nq + nv); u, p one shared row or one per case) with eom::ensemble on "
       "threads: (times (k,), states (n, k, nq + nv), status: a list of n names). times is t_eval, or "
       "[t1] without it; a state is NaN where its case stopped before that time. Bitwise the same "
       "as integrate() case by case, for any number of threads.");
  }
}

}  // namespace eom::python
