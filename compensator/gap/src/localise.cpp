// Localising a residual (docs/gap.md, step 2): phase, angle, velocity, time, spectrum, cross-correlation.
#include "pof/gap/localise.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <sstream>

#include <unsupported/Eigen/FFT>

#include "pof/base/format.hpp"

namespace pof::gap {

using Eigen::Index;
using Eigen::VectorXd;
using nlohmann::json;

const char* phase_name(Phase p) {
  switch (p) {
    case Phase::kHold: return "hold";
    case Phase::kAfterStop: return "after_stop";
    case Phase::kReversal: return "reversal";
    case Phase::kAccel: return "accel_decel";
    case Phase::kConstantVelocity: return "constant_velocity";
    case Phase::kCount: break;
  }
  return "?";
}

namespace {

const char* phase_words(Phase p) {
  switch (p) {
    case Phase::kHold: return "holds (>= 3 s after a movement)";
    case Phase::kAfterStop: return "the 3 s after a movement stops";
    case Phase::kReversal: return "reversals (first 0.5 s of a movement against the previous one)";
    case Phase::kAccel: return "acceleration/deceleration";
    case Phase::kConstantVelocity: return "constant-velocity sweeps";
    case Phase::kCount: break;
  }
  return "?";
}

struct Acc {
  double s = 0, s2 = 0;
  Index n = 0;
  void add(double x) { s += x; s2 += x * x; ++n; }
  [[nodiscard]] double rms() const { return n ? std::sqrt(s2 / static_cast<double>(n)) : 0.0; }
  [[nodiscard]] double mean() const { return n ? s / static_cast<double>(n) : 0.0; }
};

}  // namespace

std::vector<Phase> classify_phases(const Kinematics& k, double dt) {
  const Index n = k.w.size();
  std::vector<Phase> ph(static_cast<std::size_t>(n), Phase::kHold);
  double since_stop = 1e9, since_start = 1e9;
  double prev_dir = 0, seg_dir = 0;
  bool reversal_seg = false;
  for (Index i = 0; i < n; ++i) {
    const double sm = k.s_move(i);
    auto& p = ph[static_cast<std::size_t>(i)];
    if (sm == 0) {
      if (seg_dir != 0) { prev_dir = seg_dir; seg_dir = 0; since_stop = 0; }
      since_stop += dt;
      p = since_stop < 3.0 ? Phase::kAfterStop : Phase::kHold;
      continue;
    }
    if (sm != seg_dir) {  // a new movement (from a hold or a direct reversal)
      if (seg_dir != 0) prev_dir = seg_dir;
      reversal_seg = prev_dir != 0 && sm != prev_dir;
      seg_dir = sm;
      since_start = 0;
    }
    since_start += dt;
    if (reversal_seg && since_start < 0.5) p = Phase::kReversal;
    else if (std::abs(k.acc(i)) > 0.1) p = Phase::kAccel;
    else p = Phase::kConstantVelocity;
  }
  return ph;
}

json phase_rms(const VectorXd& r, const std::vector<Phase>& phases) {
  std::vector<Acc> a(static_cast<std::size_t>(Phase::kCount));
  for (Index i = 0; i < r.size(); ++i) a[static_cast<std::size_t>(phases[static_cast<std::size_t>(i)])].add(r(i));
  json j = json::object();
  for (std::size_t p = 0; p < a.size(); ++p)
    if (a[p].n) j[phase_name(static_cast<Phase>(p))] = a[p].rms();
  return j;
}

Localisation localise(const VectorXd& r, const Signals& s, const Kinematics& k, const std::vector<Phase>& phases) {
  Localisation L;
  const Index n = r.size();
  const double N = static_cast<double>(n);
  const double rms_all = std::sqrt(r.squaredNorm() / N);
  json& d = L.detail;
  d["rms_deg"] = rms_all;
  d["mean_deg"] = r.mean();

  // phases
  std::vector<Acc> pa(static_cast<std::size_t>(Phase::kCount));
  for (Index i = 0; i < n; ++i) pa[static_cast<std::size_t>(phases[static_cast<std::size_t>(i)])].add(r(i));
  d["phase"] = json::object();
  std::size_t top_phase = 0;
  double top_ratio = -1;
  for (std::size_t p = 0; p < pa.size(); ++p) {
    if (!pa[p].n) continue;
    const double frac = static_cast<double>(pa[p].n) / N;
    const double energy = pa[p].s2 / std::max(1e-300, r.squaredNorm());
    d["phase"][phase_name(static_cast<Phase>(p))] = {{"fraction_of_scans", frac}, {"rms_deg", pa[p].rms()},
                                                      {"mean_deg", pa[p].mean()}, {"fraction_of_energy", energy}};
    const double ratio = rms_all > 0 ? pa[p].rms() / rms_all : 0.0;
    if (frac >= 0.02 && ratio > top_ratio) { top_ratio = ratio; top_phase = p; }
  }

  // angle bins (10 deg) and velocity bins
  std::vector<Acc> ab(10), vb(6);
  const double vedges[] = {0.01, 0.05, 0.1, 0.2, 0.5};
  for (Index i = 0; i < n; ++i) {
    const auto bi = static_cast<std::size_t>(std::clamp(std::floor(k.angle(i) / 10.0), 0.0, 9.0));
    ab[bi].add(r(i));
    const double aw = std::abs(k.w(i));
    std::size_t vi = 0;
    while (vi < 5 && aw >= vedges[vi]) ++vi;
    vb[vi].add(r(i));
  }
  d["angle_bins"] = json::array();
  std::size_t top_a = 0;
  for (std::size_t b = 0; b < ab.size(); ++b) {
    if (!ab[b].n) continue;
    d["angle_bins"].push_back({{"from_deg", 10.0 * static_cast<double>(b)}, {"to_deg", 10.0 * static_cast<double>(b + 1)},
                               {"rms_deg", ab[b].rms()}, {"mean_deg", ab[b].mean()}, {"scans", ab[b].n}});
    if (ab[b].rms() > ab[top_a].rms() || !ab[top_a].n) top_a = b;
  }
  const char* vnames[] = {"hold <0.01", "0.01-0.05", "0.05-0.1", "0.1-0.2", "0.2-0.5", ">=0.5"};
  d["velocity_bins_rad_s"] = json::array();
  std::size_t top_v = 0;
  for (std::size_t b = 0; b < vb.size(); ++b) {
    if (!vb[b].n) continue;
    d["velocity_bins_rad_s"].push_back({{"bin", vnames[b]}, {"rms_deg", vb[b].rms()}, {"mean_deg", vb[b].mean()}, {"scans", vb[b].n}});
    if (vb[b].rms() > vb[top_v].rms() || !vb[top_v].n) top_v = b;
  }

  // time: ten equal segments
  d["time_segments"] = json::array();
  std::vector<double> tmeans;
  for (Index seg = 0; seg < 10; ++seg) {
    const Index a = seg * n / 10, e = (seg + 1) * n / 10;
    Acc t;
    for (Index i = a; i < e; ++i) t.add(r(i));
    tmeans.push_back(t.mean());
    d["time_segments"].push_back({{"from_s", s.t(a)}, {"rms_deg", t.rms()}, {"mean_deg", t.mean()}});
  }

  // spectrum
  Index nfft = 1;
  while (nfft < n) nfft *= 2;
  std::vector<double> x(static_cast<std::size_t>(nfft), 0.0);
  const double mu = r.mean();
  for (Index i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = r(i) - mu;
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> X;
  fft.fwd(X, x);
  const double df = 1.0 / (static_cast<double>(nfft) * s.dt);
  const auto half = static_cast<std::size_t>(nfft / 2);
  double total = 0, slow = 0, peak = 0;
  std::size_t pk = 1;
  for (std::size_t i = 1; i < half; ++i) {
    const double p = std::norm(X[i]);
    total += p;
    if (static_cast<double>(i) * df < 0.1) slow += p;
    if (static_cast<double>(i) * df >= 0.5 && p > peak) { peak = p; pk = i; }
  }
  double around = 0;
  for (std::size_t i = pk > 3 ? pk - 3 : 1; i <= std::min(half - 1, pk + 3); ++i) around += std::norm(X[i]);
  const double peak_frac = total > 0 ? around / total : 0.0;
  d["spectrum"] = {{"fraction_below_0_1_hz", total > 0 ? slow / total : 0.0},
                   {"peak_above_0_5_hz", static_cast<double>(pk) * df},
                   {"peak_fraction_of_power", peak_frac}};

  // cross-correlation with the inputs at lags -2..2 s, on 20 Hz block means (the inputs are slow)
  const auto dec = std::max<Index>(1, static_cast<Index>(std::lround(0.05 / s.dt)));
  const Index m = n / dec;
  auto decimate = [&](const VectorXd& v) {
    VectorXd o(m);
    double tot = 0;
    for (Index i = 0; i < m; ++i) {
      double acc = 0;
      for (Index j = i * dec; j < (i + 1) * dec; ++j) acc += v[j];
      o[i] = acc / static_cast<double>(dec);
      tot += o[i];
    }
    o.array() -= tot / static_cast<double>(std::max<Index>(1, m));
    return o;
  };
  const VectorXd rd = decimate(r);
  struct In { const char* name; VectorXd x; };
  std::vector<In> ins{{"angle", decimate(k.angle)}, {"velocity", decimate(k.w)},
                      {"speed", decimate(k.w.cwiseAbs())}, {"acceleration", decimate(k.acc)},
                      {"reference_level", decimate(s.ref_rel)}, {"last_direction", decimate(k.s_last)},
                      {"time", decimate(s.t)}};
  d["xcorr"] = json::object();
  std::string top_in;
  double top_r = 0, top_lag = 0;
  for (const In& in : ins) {
    double best = 0, blag = 0;
    const double nx = in.x.norm(), nr = rd.norm();
    if (nx > 0 && nr > 0)
      for (Index lag = -40; lag <= 40; ++lag) {  // r(t) against input(t - lag)
        const Index a = std::max<Index>(0, lag), b = std::min<Index>(m, m + lag);
        if (b - a < 10) continue;
        const double c = rd.segment(a, b - a).dot(in.x.segment(a - lag, b - a)) / (nx * nr);
        if (std::abs(c) > std::abs(best)) { best = c; blag = static_cast<double>(lag * dec) * s.dt; }
      }
    d["xcorr"][in.name] = {{"r", best}, {"lag_s", blag}};
    if (std::abs(best) > std::abs(top_r)) { top_r = best; top_in = in.name; top_lag = blag; }
  }

  // the sentence
  std::ostringstream o;
  const auto& tp = pa[top_phase];
  o << "RMS " << format_fixed(rms_all, 2) << " deg; largest in " << phase_words(static_cast<Phase>(top_phase)) << " (RMS "
    << format_fixed(tp.rms(), 2) << " deg, mean " << format_fixed(tp.mean(), 2) << " deg, " << format_fixed(100.0 * static_cast<double>(tp.n) / N, 0)
    << " % of scans)";
  o << "; by angle at " << 10 * top_a << "-" << 10 * (top_a + 1) << " deg (RMS " << format_fixed(ab[top_a].rms(), 2) << " deg)";
  o << "; by velocity at " << vnames[top_v] << " rad/s (RMS " << format_fixed(vb[top_v].rms(), 2) << " deg)";
  const double trend = tmeans.back() - tmeans.front();
  if (std::abs(trend) > 0.5 * rms_all && rms_all > 0)
    o << "; trend over time from " << format_fixed(tmeans.front(), 2) << " to " << format_fixed(tmeans.back(), 2) << " deg";
  if (peak_frac > 0.2)
    o << "; spectral peak at " << format_fixed(static_cast<double>(pk) * df, 2) << " Hz (" << format_fixed(100 * peak_frac, 0) << " % of power)";
  if (!top_in.empty())
    o << "; strongest correlation with " << top_in << " (r = " << format_fixed(top_r, 2) << " at lag " << format_fixed(top_lag, 2) << " s)";
  L.sentence = o.str();
  return L;
}

}  // namespace pof::gap
