// Peers benchmark: OpenGV (Debian's libopengv-dev) on simhc trials files.
//
//   run_opengv [--problem upnp|grps] [--repeats N] TRIALS.json > results.jsonl
//
// UPnP (alpha f + v = R p + t, (R, t) world -> viewer): opengv::absolute_pose::upnp, gpnp, gp3p
// with a NoncentralAbsoluteAdapter (one camera per distinct ray origin v, identity camera
// rotation). OpenGV returns T = [R_ov | t_ov] with p = R_ov X + t_ov (viewer -> world), so
// simhc's pose is R = R_ov^T, t = -R_ov^T t_ov.
//
// GRPS (alpha f + v = R (alpha' fp + vp) + t, scale 1): opengv::relative_pose::sixpt on the first
// 6 correspondences with a NoncentralRelativeAdapter (the camera offsets are the distinct v of
// view 1 followed by the distinct vp of view 2). OpenGV's R12, t12 map viewpoint 2 into viewpoint
// 1, i.e. simhc's (R, t) directly. sixpt returns rotations only: for each rotation t is solved by
// linear least squares on all correspondences (the generalized epipolar constraint is linear in t
// when the scale is 1) and the rotation with the smallest residual sum is kept.
// opengv::relative_pose::seventeenpt is run only with at least 17 correspondences.
//
// Output: one JSON object per line and solver and trial:
//   {"solver": "opengv.upnp", "trial": i, "rotation": [[..],[..],[..]] | null,
//    "translation": [..] | null, "micros": median per-call time, "micros_total": median time of
//    call + choice among the returned solutions, "solutions": number returned}
// Each call is repeated --repeats times (default 10); the times are the medians.

#include <opengv/absolute_pose/NoncentralAbsoluteAdapter.hpp>
#include <opengv/absolute_pose/methods.hpp>
#include <opengv/relative_pose/NoncentralRelativeAdapter.hpp>
#include <opengv/relative_pose/methods.hpp>
#include <opengv/types.hpp>

#include <nlohmann/json.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

using Eigen::Matrix3d;
using Eigen::Vector3d;
using json = nlohmann::json;
namespace gv = opengv;

namespace {

Vector3d vec3(const json& a) { return Vector3d(a.at(0).get<double>(), a.at(1).get<double>(), a.at(2).get<double>()); }

// A bearing: normalized only when not unit already (within 1e-12), else passed on bit-for-bit.
Vector3d bearing(const json& a) {
  Vector3d f = vec3(a);
  double n = f.norm();
  return std::abs(n - 1.0) > 1e-12 ? Vector3d(f / n) : f;
}

// Index of v in the list of distinct origins (exact comparison), appending it if new.
int camera_index(std::vector<Vector3d>& origins, const Vector3d& v) {
  for (size_t k = 0; k < origins.size(); ++k)
    if (origins[k] == v) return static_cast<int>(k);
  origins.push_back(v);
  return static_cast<int>(origins.size()) - 1;
}

double median(std::vector<double> xs) {
  std::sort(xs.begin(), xs.end());
  size_t n = xs.size();
  return n % 2 ? xs[n / 2] : 0.5 * (xs[n / 2 - 1] + xs[n / 2]);
}

// Median wall time in microseconds of `call` over `repeats` runs.
double time_median(int repeats, const std::function<void()>& call) {
  std::vector<double> ts;
  ts.reserve(repeats);
  for (int r = 0; r < repeats; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    call();
    auto t1 = std::chrono::steady_clock::now();
    ts.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return median(ts);
}

struct Pose {
  bool ok = false;
  Matrix3d R = Matrix3d::Identity();
  Vector3d t = Vector3d::Zero();
};

bool finite(const Pose& p) { return p.R.allFinite() && p.t.allFinite(); }

void emit(const std::string& solver, size_t trial, const Pose& pose, double micros, double micros_total, size_t nsol) {
  std::printf("{\"solver\": \"%s\", \"trial\": %zu, ", solver.c_str(), trial);
  if (pose.ok && finite(pose)) {
    std::printf("\"rotation\": [");
    for (int i = 0; i < 3; ++i)
      std::printf("%s[%.17g, %.17g, %.17g]", i ? ", " : "", pose.R(i, 0), pose.R(i, 1), pose.R(i, 2));
    std::printf("], \"translation\": [%.17g, %.17g, %.17g], ", pose.t(0), pose.t(1), pose.t(2));
  } else {
    std::printf("\"rotation\": null, \"translation\": null, ");
  }
  std::printf("\"micros\": %.4f, \"micros_total\": %.4f, \"solutions\": %zu}\n", micros, micros_total, nsol);
}

// ------------------------------------------------------------------------------------------
// UPnP
// ------------------------------------------------------------------------------------------

struct UpnpTrial {
  gv::bearingVectors_t f;
  gv::points_t p;
  std::vector<Vector3d> v;  // per correspondence
  gv::translations_t offsets;
  gv::rotations_t rotations;
  std::vector<int> cam;
};

UpnpTrial read_upnp(const json& scene) {
  UpnpTrial tr;
  std::vector<Vector3d> origins;
  for (const auto& c : scene.at("correspondences")) {
    tr.p.push_back(vec3(c.at("p")));
    tr.f.push_back(bearing(c.at("f")));
    Vector3d v = vec3(c.at("v"));
    tr.v.push_back(v);
    tr.cam.push_back(camera_index(origins, v));
  }
  for (const auto& o : origins) {
    tr.offsets.push_back(o);
    tr.rotations.push_back(Matrix3d::Identity());
  }
  return tr;
}

// OpenGV's T = [R_ov | t_ov] (viewer -> world) to simhc's world -> viewer pose.
Pose from_opengv_abs(const gv::transformation_t& T) {
  Pose pose;
  Matrix3d Rov = T.block<3, 3>(0, 0);
  Vector3d tov = T.col(3);
  pose.R = Rov.transpose();
  pose.t = -Rov.transpose() * tov;
  pose.ok = true;
  return pose;
}

// Sum over all correspondences of the angle between f_i and R p_i + t - v_i.
double angular_error_sum(const UpnpTrial& tr, const Pose& pose) {
  double s = 0;
  for (size_t i = 0; i < tr.f.size(); ++i) {
    Vector3d y = pose.R * tr.p[i] + pose.t - tr.v[i];
    s += std::atan2(tr.f[i].cross(y).norm(), tr.f[i].dot(y));
  }
  return std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
}

Pose best_abs(const UpnpTrial& tr, const gv::transformations_t& sols) {
  Pose best;
  double best_err = std::numeric_limits<double>::infinity();
  for (const auto& T : sols) {
    Pose p = from_opengv_abs(T);
    if (!finite(p)) continue;
    double e = angular_error_sum(tr, p);
    if (!best.ok || e < best_err) {
      best = p;
      best_err = e;
    }
  }
  return best;
}

void run_upnp(const json& trials, int repeats) {
  for (size_t i = 0; i < trials.size(); ++i) {
    UpnpTrial tr = read_upnp(trials[i]);
    gv::absolute_pose::NoncentralAbsoluteAdapter adapter(tr.f, tr.cam, tr.p, tr.offsets, tr.rotations);

    {  // upnp: several solutions, keep the one with the least angular error on all points
      gv::transformations_t sols;
      double us = time_median(repeats, [&] { sols = gv::absolute_pose::upnp(adapter); });
      Pose pose;
      double total = time_median(repeats, [&] { pose = best_abs(tr, gv::absolute_pose::upnp(adapter)); });
      emit("opengv.upnp", i, pose, us, total, sols.size());
    }
    {  // gpnp: one solution
      gv::transformation_t T;
      double us = time_median(repeats, [&] { T = gv::absolute_pose::gpnp(adapter); });
      Pose pose = from_opengv_abs(T);
      emit("opengv.gpnp", i, pose, us, us, 1);
    }
    {  // gp3p: minimal, first 3 correspondences; the best solution on all points
      gv::transformations_t sols;
      double us = time_median(repeats, [&] { sols = gv::absolute_pose::gp3p(adapter, 0, 1, 2); });
      Pose pose;
      double total = time_median(repeats, [&] { pose = best_abs(tr, gv::absolute_pose::gp3p(adapter, 0, 1, 2)); });
      emit("opengv.gp3p", i, pose, us, total, sols.size());
    }
  }
}

// ------------------------------------------------------------------------------------------
// GRPS
// ------------------------------------------------------------------------------------------

struct GrpsTrial {
  gv::bearingVectors_t f1, f2;
  std::vector<Vector3d> v1, v2;  // per correspondence
  gv::translations_t offsets;
  gv::rotations_t rotations;
  std::vector<int> cam1, cam2;
};

GrpsTrial read_grps(const json& scene) {
  GrpsTrial tr;
  std::vector<Vector3d> o1, o2;
  for (const auto& c : scene.at("correspondences")) {
    tr.f1.push_back(bearing(c.at("f")));
    tr.f2.push_back(bearing(c.at("fp")));
    tr.v1.push_back(vec3(c.at("v")));
    tr.v2.push_back(vec3(c.at("vp")));
    tr.cam1.push_back(camera_index(o1, tr.v1.back()));
    tr.cam2.push_back(camera_index(o2, tr.v2.back()));
  }
  // view-2 cameras are stored after the view-1 cameras in the one offsets list OpenGV takes
  for (auto& c : tr.cam2) c += static_cast<int>(o1.size());
  for (const auto& o : o1) tr.offsets.push_back(o);
  for (const auto& o : o2) tr.offsets.push_back(o);
  tr.rotations.assign(tr.offsets.size(), Matrix3d::Identity());
  return tr;
}

// Coplanarity of ray 1 (v + a f) and ray 2 mapped into view 1 (R vp + t + b R fp): the Pluecker
// form f.((R vp + t) x g) + g.(v x f) with g = R fp, i.e. a.t = b with a = g x f,
// b = -f.((R vp) x g) - g.(v x f).
void epipolar_row(const GrpsTrial& tr, size_t i, const Matrix3d& R, Vector3d& a, double& b) {
  Vector3d g = R * tr.f2[i];
  a = g.cross(tr.f1[i]);
  b = -tr.f1[i].dot((R * tr.v2[i]).cross(g)) - g.dot(tr.v1[i].cross(tr.f1[i]));
}

Pose translation_for_rotation(const GrpsTrial& tr, const Matrix3d& R, double* residual) {
  Matrix3d AtA = Matrix3d::Zero();
  Vector3d Atb = Vector3d::Zero();
  for (size_t i = 0; i < tr.f1.size(); ++i) {
    Vector3d a;
    double b;
    epipolar_row(tr, i, R, a, b);
    AtA += a * a.transpose();
    Atb += b * a;
  }
  Pose pose;
  pose.R = R;
  pose.t = AtA.ldlt().solve(Atb);
  pose.ok = finite(pose);
  double s = 0;
  for (size_t i = 0; i < tr.f1.size(); ++i) {
    Vector3d a;
    double b;
    epipolar_row(tr, i, R, a, b);
    s += (a.dot(pose.t) - b) * (a.dot(pose.t) - b);
  }
  *residual = std::isfinite(s) ? s : std::numeric_limits<double>::infinity();
  return pose;
}

Pose best_rotation(const GrpsTrial& tr, const gv::rotations_t& rots) {
  Pose best;
  double best_err = std::numeric_limits<double>::infinity();
  for (const auto& R : rots) {
    if (!R.allFinite()) continue;
    double err;
    Pose p = translation_for_rotation(tr, R, &err);
    if (p.ok && (!best.ok || err < best_err)) {
      best = p;
      best_err = err;
    }
  }
  return best;
}

void run_grps(const json& trials, int repeats) {
  bool warned = false;
  for (size_t i = 0; i < trials.size(); ++i) {
    GrpsTrial tr = read_grps(trials[i]);
    gv::relative_pose::NoncentralRelativeAdapter adapter(tr.f1, tr.f2, tr.cam1, tr.cam2, tr.offsets, tr.rotations);
    if (tr.f1.size() >= 6) {
      std::vector<int> idx = {0, 1, 2, 3, 4, 5};
      gv::rotations_t rots;
      double us = time_median(repeats, [&] { rots = gv::relative_pose::sixpt(adapter, idx); });
      Pose pose;
      double total = time_median(repeats, [&] { pose = best_rotation(tr, gv::relative_pose::sixpt(adapter, idx)); });
      emit("opengv.sixpt+lsq_t", i, pose, us, total, rots.size());
    }
    if (tr.f1.size() >= 17) {
      gv::transformation_t T;
      double us = time_median(repeats, [&] { T = gv::relative_pose::seventeenpt(adapter); });
      Pose pose;
      pose.R = T.block<3, 3>(0, 0);
      pose.t = T.col(3);
      pose.ok = true;
      emit("opengv.seventeenpt", i, pose, us, us, 1);
    } else if (!warned) {
      std::fprintf(stderr, "run_opengv: seventeenpt skipped: it needs at least 17 correspondences, the trials have %zu\n",
                   tr.f1.size());
      warned = true;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string problem, path;
  int repeats = 10;
  for (int a = 1; a < argc; ++a) {
    std::string arg = argv[a];
    if (arg == "--problem" && a + 1 < argc) {
      problem = argv[++a];
    } else if (arg == "--repeats" && a + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++a]));
    } else if (arg == "-h" || arg == "--help") {
      std::fprintf(stderr, "usage: run_opengv [--problem upnp|grps] [--repeats N] TRIALS.json > results.jsonl\n");
      return 0;
    } else {
      path = arg;
    }
  }
  if (path.empty()) {
    std::fprintf(stderr, "usage: run_opengv [--problem upnp|grps] [--repeats N] TRIALS.json > results.jsonl\n");
    return 2;
  }
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "run_opengv: cannot open %s\n", path.c_str());
    return 2;
  }
  json trials;
  try {
    trials = json::parse(in);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "run_opengv: %s: %s\n", path.c_str(), e.what());
    return 2;
  }
  if (!trials.is_array() || trials.empty()) {
    std::fprintf(stderr, "run_opengv: %s: expected a non-empty JSON array of scenes\n", path.c_str());
    return 2;
  }
  if (problem.empty()) problem = trials[0].at("correspondences").at(0).contains("fp") ? "grps" : "upnp";
  std::fprintf(stderr, "run_opengv: %zu %s trials from %s, %d repeats per call\n", trials.size(), problem.c_str(),
               path.c_str(), repeats);
  if (problem == "upnp") {
    run_upnp(trials, repeats);
  } else if (problem == "grps") {
    run_grps(trials, repeats);
  } else {
    std::fprintf(stderr, "run_opengv: unknown problem %s\n", problem.c_str());
    return 2;
  }
  return 0;
}
