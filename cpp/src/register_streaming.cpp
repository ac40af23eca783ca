// Bindings for the chunked (out-of-core) passes: phase building with carried compensated sums
// and partial sums of squared differences over separate tap windows.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "allanite/streaming.hpp"
#include "allanite/variances.hpp"
#include "bindings.hpp"

namespace py = pybind11;

namespace allanite::bind {
namespace {

/// A writable (C, 2) float64 C-contiguous state array as NeumaierSums, written back on scope exit.
class StateArray {
 public:
  StateArray(py::array& state, Eigen::Index nc) : arr_(state) {
    if (!py::isinstance<py::array_t<double>>(state) || state.ndim() != 2 || state.shape(0) != nc ||
        state.shape(1) != 2 || !(state.flags() & py::array::c_style) || !state.writeable())
      throw py::value_error("state must be a writable, C-contiguous float64 array of shape (" +
                            std::to_string(nc) + ", 2); create it with np.zeros((channels, 2))");
    auto* p = static_cast<double*>(state.mutable_data());
    for (Eigen::Index c = 0; c < nc; ++c) sums_.emplace_back(p[2 * c], p[2 * c + 1]);
  }
  void store() {
    auto* p = static_cast<double*>(arr_.mutable_data());
    for (std::size_t c = 0; c < sums_.size(); ++c) {
      p[2 * c] = sums_[c].hi();
      p[2 * c + 1] = sums_[c].lo();
    }
  }
  NeumaierSum* data() { return sums_.data(); }

 private:
  py::array& arr_;
  std::vector<NeumaierSum> sums_;
};

/// A writable (C, LaneSum::kStateSize) float64 C-contiguous array of LaneSum states (his, then
/// los), written back on scope exit.
class LaneStateArray {
 public:
  LaneStateArray(py::array& state, Eigen::Index nc) : arr_(state) {
    constexpr int width = LaneSum::kStateSize;
    if (!py::isinstance<py::array_t<double>>(state) || state.ndim() != 2 || state.shape(0) != nc ||
        state.shape(1) != width || !(state.flags() & py::array::c_style) || !state.writeable())
      throw py::value_error("state must be a writable, C-contiguous float64 array of shape (" +
                            std::to_string(nc) + ", " + std::to_string(width) +
                            "); create it with np.zeros((channels, SUM_LANES_STATE))");
    const auto* p = static_cast<const double*>(state.data());
    sums_.resize(static_cast<std::size_t>(nc));
    for (std::size_t c = 0; c < sums_.size(); ++c)
      for (int r = 0; r < LaneSum::kLanes; ++r) {
        sums_[c].hi[r] = p[c * width + r];
        sums_[c].lo[r] = p[c * width + LaneSum::kLanes + r];
      }
  }
  void store() {
    auto* p = static_cast<double*>(arr_.mutable_data());
    constexpr int width = LaneSum::kStateSize;
    for (std::size_t c = 0; c < sums_.size(); ++c)
      for (int r = 0; r < LaneSum::kLanes; ++r) {
        p[c * width + r] = sums_[c].hi[r];
        p[c * width + LaneSum::kLanes + r] = sums_[c].lo[r];
      }
  }
  LaneSum* data() { return sums_.data(); }
  [[nodiscard]] std::size_t size() const { return sums_.size(); }

 private:
  py::array& arr_;
  std::vector<LaneSum> sums_;
};

std::vector<double> per_channel(const py::array_t<double, py::array::forcecast>& v, Eigen::Index nc,
                                const char* name) {
  if (v.ndim() != 1 || v.shape(0) != nc)
    throw py::value_error(std::string(name) + " must have one value per channel (" + std::to_string(nc) + ")");
  return std::vector<double>(v.data(), v.data() + nc);
}

double* output_rows(py::array& out, Eigen::Index rows, Eigen::Index nc) {
  if (!py::isinstance<py::array_t<double>>(out) || out.ndim() != 2 || out.shape(0) != rows ||
      out.shape(1) != nc || !(out.flags() & py::array::c_style) || !out.writeable())
    throw py::value_error("out must be a writable, C-contiguous float64 array of shape (" +
                          std::to_string(rows) + ", " + std::to_string(nc) + ")");
  return static_cast<double*>(out.mutable_data());
}

/// Call fn(StridedMap<T>) for the dtype of the 2-D chunk x (the dtypes build_phase accepts).
template <class Fn>
void dispatch(const py::array& x, Fn&& fn) {
  if (x.ndim() != 2)
    throw py::value_error("chunk must be a 2-D (samples, channels) array, got " + std::to_string(x.ndim()) +
                          " dimensions");
  auto run = [&](auto tag) {
    using T = decltype(tag);
    const auto itemsize = static_cast<py::ssize_t>(sizeof(T));
    if (x.strides(0) % itemsize != 0 || x.strides(1) % itemsize != 0)
      throw py::type_error("chunk strides are not a multiple of the item size; pass np.ascontiguousarray(chunk)");
    StridedMap<T> view(static_cast<const T*>(x.data()), x.shape(0), x.shape(1),
                       Strides(x.strides(0) / itemsize, x.strides(1) / itemsize));
    fn(view);
  };
  dispatch_dtype(x, run);
}

py::array_t<double> stream_sums(const py::array& x, std::int64_t k0, py::array& state,
                                const py::array_t<double, py::array::forcecast>& a,
                                const py::array_t<double, py::array::forcecast>& b) {
  const Eigen::Index nc = x.ndim() == 2 ? x.shape(1) : 0;
  LaneStateArray st(state, nc);
  const auto va = per_channel(a, nc, "a"), vb = per_channel(b, nc, "b");
  std::vector<double> done;
  dispatch(x, [&](const auto& view) {
    py::gil_scoped_release release;
    stream::check_finite_chunk(view, k0);
    stream::add_shifted(view, k0, va.data(), vb.data(), st.data(), done);
  });
  st.store();
  py::array_t<double> out({static_cast<py::ssize_t>(done.size()) / std::max<py::ssize_t>(nc, 1),
                           static_cast<py::ssize_t>(nc)});
  std::copy(done.begin(), done.end(), out.mutable_data());
  return out;
}

py::array_t<double> stream_sums_value(py::array& state) {
  const Eigen::Index nc = state.ndim() == 2 ? state.shape(0) : 0;
  LaneStateArray st(state, nc);
  py::array_t<double> out(static_cast<py::ssize_t>(st.size()));
  auto* o = out.mutable_data();
  for (std::size_t c = 0; c < st.size(); ++c) o[c] = st.data()[c].value();
  return out;
}

/// Checked (blocks, C) C-contiguous block values.
const double* block_values(const py::array_t<double, py::array::c_style | py::array::forcecast>& v,
                           std::int64_t& nb, Eigen::Index& nc) {
  if (v.ndim() != 2) throw py::value_error("block values must be a 2-D (blocks, channels) array");
  nb = v.shape(0);
  nc = v.shape(1);
  return v.data();
}

py::array_t<double> stream_block_total(const py::array_t<double, py::array::c_style | py::array::forcecast>& v) {
  std::int64_t nb = 0;
  Eigen::Index nc = 0;
  const double* p = block_values(v, nb, nc);
  py::array_t<double> out(static_cast<py::ssize_t>(nc));
  for (Eigen::Index c = 0; c < nc; ++c) out.mutable_data()[c] = block_total(p, nb, nc, c);
  return out;
}

py::array_t<double> stream_block_bases(const py::array_t<double, py::array::c_style | py::array::forcecast>& v,
                                       const py::array_t<double, py::array::forcecast>& corr) {
  std::int64_t nb = 0;
  Eigen::Index nc = 0;
  const double* p = block_values(v, nb, nc);
  const auto cr = per_channel(corr, nc, "corr");
  const std::vector<double> bases = phase_block_bases(p, nb, nc, cr.data());
  py::array_t<double> out({static_cast<py::ssize_t>(nb), static_cast<py::ssize_t>(nc), py::ssize_t{2}});
  std::copy(bases.begin(), bases.end(), out.mutable_data());
  return out;
}

void stream_moment(const py::array& x, std::int64_t k0, double kbar,
                   const py::array_t<double, py::array::forcecast>& mean1,
                   const py::array_t<double, py::array::forcecast>& corr, py::array& state) {
  const Eigen::Index nc = x.ndim() == 2 ? x.shape(1) : 0;
  StateArray st(state, nc);
  const auto m1 = per_channel(mean1, nc, "mean1"), cr = per_channel(corr, nc, "corr");
  dispatch(x, [&](const auto& view) {
    py::gil_scoped_release release;
    stream::add_moment(view, k0, kbar, m1.data(), cr.data(), st.data());
  });
  st.store();
}

void stream_prefix(const py::array& x, std::int64_t k0, const py::array_t<double, py::array::forcecast>& mean1,
                   const py::array_t<double, py::array::forcecast>& corr,
                   const py::array_t<double, py::array::c_style | py::array::forcecast>& bases, py::array& state,
                   py::array& out) {
  const Eigen::Index nc = x.ndim() == 2 ? x.shape(1) : 0;
  StateArray st(state, nc);
  const auto m1 = per_channel(mean1, nc, "mean1"), cr = per_channel(corr, nc, "corr");
  const std::int64_t last = k0 + (x.ndim() == 2 ? x.shape(0) : 0);
  if (bases.ndim() != 3 || bases.shape(1) != nc || bases.shape(2) != 2 || bases.shape(0) < phase_blocks(last))
    throw py::value_error("bases must be the (blocks, C, 2) array of stream_block_bases for the whole record");
  double* o = output_rows(out, x.shape(0), nc);
  dispatch(x, [&](const auto& view) {
    py::gil_scoped_release release;
    stream::prefix_rows(view, k0, m1.data(), cr.data(), bases.data(), st.data(), o);
  });
  st.store();
}

void stream_detrend(const py::array& x, std::int64_t k0, double kbar,
                    const py::array_t<double, py::array::forcecast>& mean1,
                    const py::array_t<double, py::array::forcecast>& corr,
                    const py::array_t<double, py::array::forcecast>& slope, py::array& out) {
  const Eigen::Index nc = x.ndim() == 2 ? x.shape(1) : 0;
  const auto m1 = per_channel(mean1, nc, "mean1"), cr = per_channel(corr, nc, "corr"),
             sl = per_channel(slope, nc, "slope");
  double* o = output_rows(out, x.shape(0), nc);
  dispatch(x, [&](const auto& view) {
    py::gil_scoped_release release;
    stream::detrend_rows(view, k0, kbar, m1.data(), cr.data(), sl.data(), o);
  });
}

void diff_square_sums(const std::vector<py::array>& windows, std::int64_t term_stride, std::int64_t count,
                      py::array& state) {
  const std::size_t taps = windows.size();
  if (taps != 3 && taps != 4)
    throw py::value_error("give 3 windows (second differences) or 4 (third differences), got " +
                          std::to_string(taps));
  if (term_stride < 1) throw py::value_error("term_stride must be at least 1");
  if (count < 0) throw py::value_error("count must be non-negative");
  const Eigen::Index nc = windows[0].ndim() == 2 ? windows[0].shape(1) : 0;
  const std::int64_t need = count == 0 ? 0 : (count - 1) * term_stride + 1;
  std::vector<const double*> ptr;
  for (const auto& w : windows) {
    if (!py::isinstance<py::array_t<double>>(w) || w.ndim() != 2 || w.shape(1) != nc ||
        !(w.flags() & py::array::c_style))
      throw py::value_error("windows must be C-contiguous float64 arrays of shape (rows, " +
                            std::to_string(nc) + ")");
    if (w.shape(0) < need)
      throw py::value_error("window has " + std::to_string(w.shape(0)) + " rows, " + std::to_string(need) +
                            " needed for " + std::to_string(count) + " terms");
    ptr.push_back(static_cast<const double*>(w.data()));
  }
  StateArray st(state, nc);
  {
    py::gil_scoped_release release;
    if (taps == 3) {
      const detail::Taps<2> t{{ptr[0], ptr[1], ptr[2]}, term_stride * nc};
      detail::add_diff_squares(t, count, nc, st.data());
    } else {
      const detail::Taps<3> t{{ptr[0], ptr[1], ptr[2], ptr[3]}, term_stride * nc};
      detail::add_diff_squares(t, count, nc, st.data());
    }
  }
  st.store();
}

}  // namespace

void register_streaming(py::module_& m) {
  m.attr("SUM_BLOCK") = detail::kSumBlock;
  m.attr("PHASE_BLOCK") = kPhaseBlock;
  m.attr("SUM_LANES_STATE") = LaneSum::kStateSize;
  m.def("stream_sums", &stream_sums, py::arg("x"), py::arg("k0"), py::arg("state"), py::arg("a"), py::arg("b"),
        "Sums of (x[k, c] - a[c]) - b[c] over the PHASE_BLOCK blocks of samples of a chunk (first sample "
        "k0): returns the values (blocks, C) of the blocks completed in it; the current block's lanes are "
        "carried in state (C, SUM_LANES_STATE). Checks that the chunk is finite.");
  m.def("stream_sums_value", &stream_sums_value, py::arg("state"),
        "Values (C,) of the partial block carried in a stream_sums state (the record's last block).");
  m.def("stream_block_total", &stream_block_total, py::arg("values"),
        "Totals (C,) of block values (blocks, C), in block order (the rounding of build_phase's means).");
  m.def("stream_block_bases", &stream_block_bases, py::arg("values"), py::arg("corr"),
        "Starting states (blocks, C, 2) of the accumulation in every block, from the second pass's block "
        "values and the mean correction.");
  m.def("stream_moment", &stream_moment, py::arg("x"), py::arg("k0"), py::arg("kbar"), py::arg("mean1"),
        py::arg("corr"), py::arg("state"),
        "state[c] += sum_k (k0 + k - kbar) ((x[k, c] - mean1[c]) - corr[c]).");
  m.def("stream_prefix", &stream_prefix, py::arg("x"), py::arg("k0"), py::arg("mean1"), py::arg("corr"),
        py::arg("bases"), py::arg("state"), py::arg("out"),
        "Rate/increment phase rows of a chunk (first sample k0) into out (L, C); state (C, 2) carries the "
        "sum, restarted from bases at every block.");
  m.def("stream_detrend", &stream_detrend, py::arg("x"), py::arg("k0"), py::arg("kbar"), py::arg("mean1"),
        py::arg("corr"), py::arg("slope"), py::arg("out"), "Angle phase rows (least-squares residual) into out.");
  m.def("diff_square_sums", &diff_square_sums, py::arg("windows"), py::arg("term_stride"), py::arg("count"),
        py::arg("state"),
        "state[c] += sum_{j<count} d(j, c)^2, d the second (3 windows) or third (4 windows) difference "
        "of rows j * term_stride of the windows; the first term must sit on a SUM_BLOCK boundary.");
}

}  // namespace allanite::bind
