// OMPL's C++ planners on an nhsim planning problem, for `nhsim bench plan`.
//
// The problem file (written by sim/tools/bench/ompl_native/problem.py) holds the world, the robot's
// footprint and the distance grid of nhsim's FastChecker, so the validity checker below returns
// FastChecker's verdict for every pose: the grid's proven verdicts first, nhsim's exact
// CollisionChecker (same formulas, same operation order) for the poses the grid leaves undecided.
// Motions are checked along the exact Reeds-Shepp / Dubins curve every `step` metres of curve (the
// state space's validSegmentCount is overridden: OMPL 1.5 counts segments per component), by a motion
// validator that solves each curve once, as OMPL's own does, checks the poses nhsim checks (every
// segment's end included) in OMPL's bisection order.
// The goal is nhsim's goal region (position within its tolerance and heading within its tolerance),
// sampled at the goal pose itself, as nhsim's planners root their goal trees there; with the `region`
// flag its samples are the problem file's region poses (nhsim's goal_region_poses), the poses rrt-star
// with region_goal aims at, so OMPL's planners may end their paths anywhere in the region as ours do.
// Solves are timed as OMPL's users run them: ss.solve(timedPlannerTerminationCondition(limit)), no
// watchdog thread (ss.solve(double) starts one for limits of 1 s or more; `watchdog` asks for it).
// That condition is OMPL's `time::now() > end` on the system clock; here it is the same test on the
// steady clock the harness times with (and nhsim's planners count their budgets on), so a system clock
// being slewed (measured at +0.48 % on this machine) neither shortens nor stretches OMPL's budget.
//
// Usage:
//   harness check PROBLEM POSES OUT          verdicts (uint8, 1 = free) of the (M, 3) float64 poses
//   harness motions PROBLEM PAIRS OUT        verdicts of the motions between (M, 6) float64 pose pairs
//   harness plan PROBLEM PLANNER LIMIT TRIALS SEED
//                                            PLANNER: RRTConnect (stops at its first path) or RRTstar
//                                            (runs LIMIT seconds); prints one JSON object: the trials
//                                            and the states of the last path found
//   harness serve PROBLEM SEED               one trial per stdin line "PLANNER LIMIT [watchdog] [probe]
//                                            [range=M]", one JSON line each; `watchdog`: time ss.solve(LIMIT)
//                                            (OMPL's watchdog thread) instead; `probe`: also report when the
//                                            last validity check returned (a clock read per check); `range`:
//                                            set the planner's range [m]; `warm`: first an untimed solve
//                                            (at most 50 ms), so the timed one does not start cold from
//                                            the wait on stdin; `region`: the goal's samples are the
//                                            problem's region poses, not the goal pose alone
//   PLANNER: RRTConnect, or an asymptotically optimal one run for LIMIT seconds on path length: RRTstar,
//            RRTstar+informed, RRTstar+rejection, InformedRRTstar, SORRTstar, BITstar, ABITstar, AITstar,
//            RRTXstatic, RRTsharp
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/DubinsStateSpace.h>
#include <ompl/base/spaces/ReedsSheppStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/base/PlannerData.h>
#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/geometric/planners/informedtrees/ABITstar.h>
#include <ompl/geometric/planners/informedtrees/AITstar.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTXstatic.h>
#include <ompl/geometric/planners/rrt/RRTsharp.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/geometric/planners/rrt/SORRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <queue>
#include <sstream>
#include <iostream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

const double kInf = std::numeric_limits<double>::infinity();
const double kWarmUp = 0.05;  // longest untimed solve before a `warm` trial [s]

struct Pt {
    double x, y;
};

struct Obstacle {
    std::string kind;            // circle, ellipse, box, polygon
    double cx = 0, cy = 0;       // centre [m]
    double a = 0, b = 0;         // radius (circle), semi-axes (ellipse), full size (box) [m]
    double angle = 0;            // [rad]
    std::vector<Pt> vertices;    // polygon, counter-clockwise

    // Point (x, y) in the shape's frame, folded into its first quadrant (planning/core/world.py).
    void folded(double x, double y, double &q0, double &q1) const {
        double c = std::cos(angle), s = std::sin(angle);
        double d0 = x - cx, d1 = y - cy;
        q0 = std::fabs(c * d0 + s * d1);
        q1 = std::fabs(-s * d0 + c * d1);
    }

    double ellipse(double x, double y) const {
        double q0, q1;
        folded(x, y, q0, q1);
        double y0, y1, e0, e1;
        if (a >= b) {
            y0 = q0; y1 = q1; e0 = a; e1 = b;
        } else {
            y0 = q1; y1 = q0; e0 = b; e1 = a;
        }
        double dist;
        if (y1 > 0 && y0 > 0) {
            double lo = -e1 * e1 + e1 * y1;
            double hi = -e1 * e1 + std::sqrt(e0 * e0 * y0 * y0 + e1 * e1 * y1 * y1);
            for (int k = 0; k < 60; ++k) {
                double mid = 0.5 * (lo + hi);
                double r0 = e0 * y0 / (mid + e0 * e0), r1 = e1 * y1 / (mid + e1 * e1);
                double f = r0 * r0 + r1 * r1 - 1.0;
                if (f > 0) lo = mid; else hi = mid;
            }
            double t = 0.5 * (lo + hi);
            double x0 = e0 * e0 * y0 / (t + e0 * e0);
            double x1 = e1 * e1 * y1 / (t + e1 * e1);
            dist = std::hypot(x0 - y0, x1 - y1);
        } else if (y1 > 0) {
            dist = std::fabs(y1 - e1);
        } else {
            double thresh = (e0 * e0 - e1 * e1) / e0;
            double x0 = e0, x1 = 0.0;
            if (y0 < thresh) {
                x0 = e0 * e0 * y0 / std::max(e0 * e0 - e1 * e1, 1e-300);
                double r = x0 / e0;
                x1 = e1 * std::sqrt(std::max(1.0 - r * r, 0.0));
            }
            dist = std::hypot(x0 - y0, x1);
        }
        double u = q0 / a, v = q1 / b;
        return u * u + v * v < 1.0 ? -dist : dist;
    }

    double box(double x, double y) const {
        double q0, q1;
        folded(x, y, q0, q1);
        double d0 = q0 - 0.5 * a, d1 = q1 - 0.5 * b;
        double outside = std::hypot(std::max(d0, 0.0), std::max(d1, 0.0));
        double inside = std::min(std::max(d0, d1), 0.0);
        return outside + inside;
    }

    double polygon(double x, double y) const {
        double dist = kInf;
        int crossings = 0;
        size_t n = vertices.size();
        for (size_t i = 0; i < n; ++i) {
            const Pt &p = vertices[i], &q = vertices[(i + 1) % n];
            double ab0 = q.x - p.x, ab1 = q.y - p.y;
            double ap0 = x - p.x, ap1 = y - p.y;
            double t = std::min(std::max((ap0 * ab0 + ap1 * ab1) / (ab0 * ab0 + ab1 * ab1), 0.0), 1.0);
            dist = std::min(dist, std::hypot(x - (p.x + t * ab0), y - (p.y + t * ab1)));
            if ((p.y > y) != (q.y > y)) {
                double xint = p.x + (y - p.y) * ab0 / (q.y - p.y);
                if (x < xint) ++crossings;
            }
        }
        return crossings % 2 == 1 ? -dist : dist;
    }

    double signed_distance(double x, double y) const {
        if (kind == "circle") return std::hypot(x - cx, y - cy) - a;
        if (kind == "ellipse") return ellipse(x, y);
        if (kind == "box") return box(x, y);
        return polygon(x, y);
    }
};

struct Problem {
    double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
    bool walls = true, disc = false;
    double radius = 0, clearance = 0, tolerance = 0;
    std::vector<Pt> footprint, boundary, anchors;
    std::vector<Obstacle> obstacles;
    long nx = 0, ny = 0;
    double h = 0;
    std::vector<double> grid;
    std::string space = "reeds_shepp";
    double rho = 1, step = 0.01, goal_tolerance = 0.05, heading_tolerance = 0.1;
    double start[3] = {0, 0, 0}, goal[3] = {0, 0, 0};
    std::vector<double> region;  // poses spread over the goal region, x, y, yaw each (the goal pose first)
};

std::vector<Pt> read_points(std::istream &in) {
    long n;
    in >> n;
    std::vector<Pt> out(n);
    for (auto &p : out) in >> p.x >> p.y;
    return out;
}

Problem read_problem(const std::string &path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read problem file " + path);
    Problem pb;
    std::string key, grid_path;
    in >> key;
    if (key != "nhsim-ompl-problem") throw std::runtime_error(path + " is not an nhsim problem file");
    int version;
    in >> version;
    if (version != 3) throw std::runtime_error(path + ": problem format " + std::to_string(version) + ", expected 3");
    while (in >> key) {
        if (key == "bounds") in >> pb.xmin >> pb.xmax >> pb.ymin >> pb.ymax;
        else if (key == "walls") in >> pb.walls;
        else if (key == "disc") in >> pb.disc;
        else if (key == "radius") in >> pb.radius;
        else if (key == "clearance") in >> pb.clearance;
        else if (key == "tolerance") in >> pb.tolerance;
        else if (key == "footprint") pb.footprint = read_points(in);
        else if (key == "boundary") pb.boundary = read_points(in);
        else if (key == "anchors") pb.anchors = read_points(in);
        else if (key == "grid") in >> pb.nx >> pb.ny >> pb.h >> grid_path;
        else if (key == "space") in >> pb.space >> pb.rho >> pb.step;
        else if (key == "start") in >> pb.start[0] >> pb.start[1] >> pb.start[2];
        else if (key == "region") {
            long n;
            in >> n;
            pb.region.resize(3 * static_cast<size_t>(n));
            for (auto &v : pb.region) in >> v;
        }
        else if (key == "goal")
            in >> pb.goal[0] >> pb.goal[1] >> pb.goal[2] >> pb.goal_tolerance >> pb.heading_tolerance;
        else if (key == "circle" || key == "ellipse" || key == "box" || key == "polygon") {
            Obstacle o;
            o.kind = key;
            if (key == "circle") in >> o.cx >> o.cy >> o.a;
            else if (key == "polygon") o.vertices = read_points(in);
            else in >> o.cx >> o.cy >> o.a >> o.b >> o.angle;
            pb.obstacles.push_back(o);
        } else throw std::runtime_error("unknown key " + key + " in " + path);
        if (!in) throw std::runtime_error("malformed value after " + key + " in " + path);
    }
    if (pb.nx > 0) {
        size_t slash = path.rfind('/');  // the grid file sits next to the problem file
        if (slash != std::string::npos) grid_path = path.substr(0, slash + 1) + grid_path;
        pb.grid.resize(pb.nx * pb.ny);
        std::FILE *f = std::fopen(grid_path.c_str(), "rb");
        if (!f || std::fread(pb.grid.data(), sizeof(double), pb.grid.size(), f) != pb.grid.size())
            throw std::runtime_error("cannot read the distance grid " + grid_path);
        std::fclose(f);
    }
    return pb;
}

// FastChecker's verdict (planning/collision/grid.py and exact.py).
class Checker {
public:
    explicit Checker(const Problem &pb) : pb_(pb), e_(pb.h / std::sqrt(2.0)) {}

    bool free(double x, double y, double th) const {
        int c = pb_.walls ? classify(x, y, th) : -1;
        return c < 0 ? exact_free(x, y, th) : c == 1;
    }

    // 1 proven free, 0 proven in collision, -1 undecided (grid.py's _classify).
    int classify(double px, double py, double th) const {
        const double radius = pb_.radius, clearance = pb_.clearance, tol = pb_.tolerance;
        double g = lookup(px, py);
        if (pb_.disc) {
            if (g - e_ - radius > clearance) return 1;
            if (g + e_ - radius <= clearance) return 0;
            return -1;
        }
        if (g - e_ - radius > clearance + tol) return 1;
        double c = std::cos(th), s = std::sin(th);
        bool all_free = true;
        for (const Pt &b : pb_.boundary) {
            double gb = lookup(px + c * b.x - s * b.y, py + s * b.x + c * b.y);
            if (gb + e_ - 0.5 * tol <= clearance) return 0;
            if (gb - e_ - 0.5 * tol <= clearance) all_free = false;
        }
        for (const Pt &a : pb_.anchors) {
            double dx = a.x - px, dy = a.y - py;
            if (dx * dx + dy * dy > radius * radius) continue;
            if (inside_footprint(c * dx + s * dy, -s * dx + c * dy, false)) return 0;
        }
        return all_free ? 1 : -1;
    }

    // CollisionChecker.poses_free for one pose (exact.py).
    bool exact_free(double x, double y, double th) const {
        double centre = world_distance(x, y);
        double out = centre - pb_.radius;
        if (!pb_.disc && centre <= pb_.radius + pb_.clearance + pb_.tolerance) out = footprint_clearance(x, y, th);
        return out > pb_.clearance;
    }

private:
    double lookup(double x, double y) const {
        double fi = std::floor((x - pb_.xmin) / pb_.h + 0.5), fj = std::floor((y - pb_.ymin) / pb_.h + 0.5);
        if (!(fi >= 0 && fj >= 0 && fi < pb_.nx && fj < pb_.ny)) return -kInf;
        return pb_.grid[static_cast<long>(fi) * pb_.ny + static_cast<long>(fj)];
    }

    double wall_distance(double x, double y) const {
        return std::min(std::min(x - pb_.xmin, pb_.xmax - x), std::min(y - pb_.ymin, pb_.ymax - y));
    }

    double world_distance(double x, double y) const {
        double d = pb_.walls ? wall_distance(x, y) : kInf;
        for (const Obstacle &o : pb_.obstacles) d = std::min(d, o.signed_distance(x, y));
        return d;
    }

    // Whether body-frame point (lx, ly) is inside the footprint; `closed` counts the boundary in.
    bool inside_footprint(double lx, double ly, bool closed) const {
        size_t n = pb_.footprint.size();
        for (size_t v = 0; v < n; ++v) {
            const Pt &a = pb_.footprint[v], &b = pb_.footprint[(v + 1) % n];
            double cross = (b.x - a.x) * (ly - a.y) - (b.y - a.y) * (lx - a.x);
            if (closed ? !(cross >= 0.0) : cross < 0.0) return false;
        }
        return true;
    }

    double footprint_clearance(double x, double y, double th) const {
        double c = std::cos(th), s = std::sin(th);
        double sd = kInf;
        for (const Pt &b : pb_.boundary) sd = std::min(sd, world_distance(x + c * b.x - s * b.y, y + s * b.x + c * b.y));
        for (const Pt &a : pb_.anchors) {
            double dx = a.x - x, dy = a.y - y;
            if (inside_footprint(c * dx + s * dy, -s * dx + c * dy, true)) return -kInf;
        }
        return sd - 0.5 * pb_.tolerance;
    }

    const Problem &pb_;
    double e_;
};

// A curve space whose motions are checked every `step` metres of curve.
template <class Base>
class DenseCurveSpace : public Base {
public:
    DenseCurveSpace(double rho, double step) : Base(rho), rho_(rho), step_(step) {}
    unsigned int validSegmentCount(const ob::State *a, const ob::State *b) const override {
        return segments(this->distance(a, b));
    }
    // Checked segments of a curve `length` metres long.
    unsigned int segments(double length) const {
        return std::max(1u, static_cast<unsigned int>(std::ceil(length / step_)));
    }
    double rho() const { return rho_; }

private:
    double rho_, step_;
};

using DenseRS = DenseCurveSpace<ob::ReedsSheppStateSpace>;
using DenseDubins = DenseCurveSpace<ob::DubinsStateSpace>;

// What one solve cost: validity checks (states), motion checks, and (probe) when the last check returned.
struct Counters {
    long states = 0, motions = 0;
    bool probe = false;
    std::chrono::steady_clock::time_point last;
};

// OMPL's ReedsShepp/DubinsMotionValidator::checkMotion (the end state first, then the interior in
// bisection order) on the poses nhsim checks (planning/curves/words.py _sample_word): each segment of
// the curve cut into ceil(length / step) equal pieces, so every segment's end (a cusp where the car
// reverses) is checked. OMPL's own validator spaces its states evenly over the whole curve and steps
// over the cusps, where a car parking in a slot touches the kerb: its paths there graze obstacles
// nhsim's checks refuse. The curve is solved once for its segments and its states.
template <class Space, class CurvePath>
class DenseMotionValidator : public ob::MotionValidator {
public:
    DenseMotionValidator(const ob::SpaceInformationPtr &si, Counters &count)
        : ob::MotionValidator(si), space_(si->getStateSpace()->as<Space>()), count_(count) {}

    bool checkMotion(const ob::State *s1, const ob::State *s2) const override {
        ++count_.motions;
        if (!si_->isValid(s2)) {
            invalid_++;
            return false;
        }
        CurvePath path = solve(s1, s2);
        std::vector<double> &t = fractions_;  // of the curve's length, the interior poses nhsim checks
        t.clear();
        double total = path.length(), done = 0.0;
        for (double seg : path.length_) {
            double len = std::fabs(seg);
            if (len == 0.0) continue;
            int n = static_cast<int>(space_->segments(len * space_->rho()));
            for (int j = 1; j <= n; ++j) t.push_back((done + len * j / n) / total);
            done += len;
        }
        if (!t.empty()) t.pop_back();  // the end state, checked first
        bool result = true, first = false;  // the path is solved: interpolate reuses it
        if (!t.empty()) {
            std::queue<std::pair<int, int>> pos;
            pos.emplace(0, static_cast<int>(t.size()) - 1);
            ob::State *test = si_->allocState();
            while (!pos.empty()) {
                std::pair<int, int> x = pos.front();
                int mid = (x.first + x.second) / 2;
                space_->interpolate(s1, s2, t[mid], first, path, test);
                if (!si_->isValid(test)) {
                    result = false;
                    break;
                }
                pos.pop();
                if (x.first < mid) pos.emplace(x.first, mid - 1);
                if (x.second > mid) pos.emplace(mid + 1, x.second);
            }
            si_->freeState(test);
        }
        if (result) valid_++;
        else invalid_++;
        return result;
    }

    bool checkMotion(const ob::State *s1, const ob::State *s2, std::pair<ob::State *, double> &) const override {
        throw std::runtime_error("the harness's motion validator does not report the last valid state");
    }

private:
    CurvePath solve(const ob::State *s1, const ob::State *s2) const;
    const Space *space_;
    Counters &count_;
    mutable std::vector<double> fractions_;
};

template <>
ob::ReedsSheppStateSpace::ReedsSheppPath DenseMotionValidator<DenseRS, ob::ReedsSheppStateSpace::ReedsSheppPath>::solve(
    const ob::State *s1, const ob::State *s2) const {
    return space_->reedsShepp(s1, s2);
}

template <>
ob::DubinsStateSpace::DubinsPath DenseMotionValidator<DenseDubins, ob::DubinsStateSpace::DubinsPath>::solve(
    const ob::State *s1, const ob::State *s2) const {
    return space_->dubins(s1, s2);
}

double wrap(double a) { return a - 2.0 * M_PI * std::floor((a + M_PI) / (2.0 * M_PI)); }  // [-pi, pi)

void set_pose(ob::State *s, const double *q) {
    auto *se2 = s->as<ob::SE2StateSpace::StateType>();
    se2->setX(q[0]);
    se2->setY(q[1]);
    se2->setYaw(wrap(q[2]));
}

// nhsim's goal region (planning/planners/sampling/tree.py in_goal): position within `goal_tolerance`
// and heading within `heading_tolerance` of the goal pose. Its one sample is the goal pose, or, with
// `sample_region`, its samples are the problem's region poses in turn (a countable set, as OMPL's
// informed samplers need: they take maxSampleCount() samples as the foci of their ellipsoids). Its
// distance is the planar distance to the goal position, its threshold the position tolerance, so
// OMPL's cost-to-go heuristic (distance less threshold) never exceeds a path's length to the region.
class RegionGoal : public ob::GoalSampleableRegion {
public:
    RegionGoal(const ob::SpaceInformationPtr &si, const Problem &pb, bool sample_region)
        : ob::GoalSampleableRegion(si), pb_(pb) {
        setThreshold(pb.goal_tolerance);
        if (sample_region && pb.region.empty()) throw std::runtime_error("the problem file has no region poses");
        const size_t n = sample_region ? pb.region.size() / 3 : 1;
        for (size_t k = 0; k < n; ++k) {
            goals_.push_back(si->allocState());
            set_pose(goals_.back(), sample_region ? &pb.region[3 * k] : pb.goal);
        }
    }
    ~RegionGoal() override {
        for (auto *g : goals_) si_->freeState(g);
    }

    double distanceGoal(const ob::State *s) const override {
        const auto *q = s->as<ob::SE2StateSpace::StateType>();
        return std::hypot(q->getX() - pb_.goal[0], q->getY() - pb_.goal[1]);
    }
    bool isSatisfied(const ob::State *s) const override { return isSatisfied(s, nullptr); }
    bool isSatisfied(const ob::State *s, double *distance) const override {
        const auto *q = s->as<ob::SE2StateSpace::StateType>();
        double d = distanceGoal(s);
        if (distance != nullptr) *distance = d;
        return d <= pb_.goal_tolerance && std::fabs(wrap(q->getYaw() - pb_.goal[2])) <= pb_.heading_tolerance;
    }
    void sampleGoal(ob::State *s) const override { si_->copyState(s, goals_[next_++ % goals_.size()]); }
    unsigned int maxSampleCount() const override { return static_cast<unsigned int>(goals_.size()); }

private:
    const Problem &pb_;
    std::vector<ob::State *> goals_;
    mutable size_t next_ = 0;
};

// The planners raced, by name: RRTConnect, and the asymptotically optimal ones OMPL 1.5 runs on a
// Reeds-Shepp space (RRTstar with its options; the informed trees; RRTX and RRT#).
ob::PlannerPtr make_planner(const std::string &name, const ob::SpaceInformationPtr &si) {
    if (name == "RRTConnect") return std::make_shared<og::RRTConnect>(si);
    if (name == "RRTstar") return std::make_shared<og::RRTstar>(si);
    if (name == "RRTstar+informed") {  // informed sampling and new-state rejection (sample rejection excludes it)
        auto p = std::make_shared<og::RRTstar>(si);
        p->setInformedSampling(true);
        p->setNewStateRejection(true);
        return p;
    }
    if (name == "RRTstar+rejection") {  // sample rejection and new-state rejection
        auto p = std::make_shared<og::RRTstar>(si);
        p->setSampleRejection(true);
        p->setNewStateRejection(true);
        return p;
    }
    if (name == "InformedRRTstar") return std::make_shared<og::InformedRRTstar>(si);
    if (name == "SORRTstar") return std::make_shared<og::SORRTstar>(si);
    if (name == "BITstar") return std::make_shared<og::BITstar>(si);
    if (name == "ABITstar") return std::make_shared<og::ABITstar>(si);
    if (name == "AITstar") return std::make_shared<og::AITstar>(si);
    if (name == "RRTXstatic") return std::make_shared<og::RRTXstatic>(si);
    if (name == "RRTsharp") return std::make_shared<og::RRTsharp>(si);
    throw std::runtime_error("unknown planner " + name +
                             ": choose RRTConnect, RRTstar, RRTstar+informed, RRTstar+rejection, InformedRRTstar, "
                             "SORRTstar, BITstar, ABITstar, AITstar, RRTXstatic or RRTsharp");
}

struct Trial {
    bool solved;
    double time_s, first_s, length_m, last_check_s;
    long states, motions, nodes;
    std::vector<double> path;  // x, y, yaw of each state of the path found
};

struct Options {
    bool watchdog = false, probe = false, warm = false, region = false;
    double range = 0.0;  // the planner's range [m] when > 0, else its default (0.2 x the space's extent)
};

// OMPL's timedPlannerTerminationCondition(limit) (`time::now() > end`, no thread) on the steady clock.
ob::PlannerTerminationCondition steady_deadline(double limit) {
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(limit));
    return ob::PlannerTerminationCondition([end] { return std::chrono::steady_clock::now() > end; });
}

Trial solve_once(const Problem &pb, const Checker &chk, const ob::StateSpacePtr &space, const std::string &planner,
                 double limit, Options opt = {}) {
    Counters count;
    count.probe = opt.probe;
    og::SimpleSetup ss(space);
    ss.setStateValidityChecker([&chk, &count](const ob::State *s) {
        const auto *q = s->as<ob::SE2StateSpace::StateType>();
        bool ok = chk.free(q->getX(), q->getY(), q->getYaw());
        ++count.states;
        if (count.probe) count.last = std::chrono::steady_clock::now();
        return ok;
    });
    ob::SpaceInformationPtr si = ss.getSpaceInformation();
    if (pb.space == "dubins")
        si->setMotionValidator(
            std::make_shared<DenseMotionValidator<DenseDubins, ob::DubinsStateSpace::DubinsPath>>(si, count));
    else
        si->setMotionValidator(
            std::make_shared<DenseMotionValidator<DenseRS, ob::ReedsSheppStateSpace::ReedsSheppPath>>(si, count));
    ob::ScopedState<> start(space);
    set_pose(start.get(), pb.start);
    ss.setStartState(start);
    ss.setGoal(std::make_shared<RegionGoal>(si, pb, opt.region));
    double first = -1.0;
    auto t0 = std::chrono::steady_clock::now();
    auto since = [&t0](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(t - t0).count();
    };
    ob::PlannerPtr p = make_planner(planner, si);
    if (opt.range > 0) p->params().setParam("range", std::to_string(opt.range));
    ss.setPlanner(p);
    if (planner != "RRTConnect") {
        auto obj = std::make_shared<ob::PathLengthOptimizationObjective>(si);
        obj->setCostThreshold(ob::Cost(0.0));  // never satisfied: the planner spends its whole budget
        ss.setOptimizationObjective(obj);
        ss.getProblemDefinition()->setIntermediateSolutionCallback(
            [&](const ob::Planner *, const std::vector<const ob::State *> &, const ob::Cost) {
                if (first < 0) first = since(std::chrono::steady_clock::now());
            });
    }
    t0 = std::chrono::steady_clock::now();
    if (opt.watchdog) ss.solve(limit);
    else ss.solve(steady_deadline(limit));
    double dt = since(std::chrono::steady_clock::now());
    double nan = std::numeric_limits<double>::quiet_NaN();
    ob::PlannerData data(si);  // after the clock stopped
    ss.getPlannerData(data);
    Trial t{ss.haveExactSolutionPath(), dt,           first, nan, opt.probe ? since(count.last) : nan,
            count.states,              count.motions, static_cast<long>(data.numVertices()), {}};
    if (t.solved) {
        const og::PathGeometric &path = ss.getSolutionPath();
        t.length_m = path.length();
        for (std::size_t k = 0; k < path.getStateCount(); ++k) {
            const auto *q = path.getState(k)->as<ob::SE2StateSpace::StateType>();
            t.path.insert(t.path.end(), {q->getX(), q->getY(), q->getYaw()});
        }
    }
    if (planner == "RRTConnect" && t.solved) t.first_s = dt;
    return t;
}

std::string num(double v) {
    if (!std::isfinite(v)) return "null";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

ob::StateSpacePtr make_space(const Problem &pb) {
    ob::StateSpacePtr space;
    if (pb.space == "dubins") space = std::make_shared<DenseDubins>(pb.rho, pb.step);
    else space = std::make_shared<DenseRS>(pb.rho, pb.step);
    ob::RealVectorBounds bounds(2);
    bounds.setLow(0, pb.xmin);
    bounds.setHigh(0, pb.xmax);
    bounds.setLow(1, pb.ymin);
    bounds.setHigh(1, pb.ymax);
    space->as<ob::SE2StateSpace>()->setBounds(bounds);
    return space;
}

void print_trial(const Trial &t, const char *sep) {
    std::printf("%s{\"solved\": %s, \"time_s\": %s, \"first_s\": %s, \"length_m\": %s, \"last_check_s\": %s, "
                "\"states\": %ld, \"motions\": %ld, \"nodes\": %ld}",
                sep, t.solved ? "true" : "false", num(t.time_s).c_str(), num(t.first_s < 0 ? NAN : t.first_s).c_str(),
                num(t.length_m).c_str(), num(t.last_check_s).c_str(), t.states, t.motions, t.nodes);
}

int plan(const Problem &pb, const std::string &planner, double limit, int trials, unsigned seed) {
    ompl::RNG::setSeed(seed);
    Checker chk(pb);
    ob::StateSpacePtr space = make_space(pb);
    solve_once(pb, chk, space, "RRTConnect", std::min(limit, 0.2));  // warm-up (grid pages, allocators)
    std::printf("{\"planner\": \"%s\", \"time_limit_s\": %s, \"seed\": %u, \"trials\": [", planner.c_str(),
                num(limit).c_str(), seed);
    std::vector<double> last;
    for (int k = 0; k < trials; ++k) {
        Trial t = solve_once(pb, chk, space, planner, limit);
        print_trial(t, k ? ", " : "");
        if (t.solved) last = t.path;
    }
    std::printf("], \"path\": [");  // the last path found, [[x, y, yaw], ...]
    for (size_t k = 0; k < last.size(); k += 3)
        std::printf("%s[%s, %s, %s]", k ? ", " : "", num(last[k]).c_str(), num(last[k + 1]).c_str(),
                    num(last[k + 2]).c_str());
    std::printf("]}\n");
    return 0;
}

// One warm process for many trials: each stdin line "PLANNER LIMIT [watchdog] [probe]" runs one trial
// and prints it as one JSON line (the bench interleaves these with its own runs).
int serve(const Problem &pb, unsigned seed) {
    ompl::RNG::setSeed(seed);
    Checker chk(pb);
    ob::StateSpacePtr space = make_space(pb);
    solve_once(pb, chk, space, "RRTConnect", 0.2);  // warm-up
    std::string line;
    while (std::getline(std::cin, line)) {
        std::istringstream in(line);
        std::string planner, flag;
        double limit;
        if (!(in >> planner >> limit)) throw std::runtime_error("bad request \"" + line + "\": PLANNER LIMIT [flags]");
        Options opt;
        while (in >> flag) {
            if (flag == "watchdog") opt.watchdog = true;
            else if (flag == "probe") opt.probe = true;
            else if (flag == "warm") opt.warm = true;
            else if (flag == "region") opt.region = true;
            else if (flag.rfind("range=", 0) == 0) opt.range = std::stod(flag.substr(6));
            else throw std::runtime_error("unknown flag " + flag + ": watchdog, probe, warm, region or range=METRES");
        }
        if (opt.warm) solve_once(pb, chk, space, planner, std::min(limit, kWarmUp), opt);  // untimed
        print_trial(solve_once(pb, chk, space, planner, limit, opt), "");
        std::printf("\n");
        std::fflush(stdout);
    }
    return 0;
}

// Verdicts (uint8, 1 = free) of the motions between the (M, 6) float64 pose pairs [x0 y0 th0 x1 y1 th1],
// by the harness's motion validator (the start pose is not checked, as in OMPL).
int motions(const Problem &pb, const std::string &pairs_path, const std::string &out_path) {
    std::ifstream in(pairs_path, std::ios::binary | std::ios::ate);
    if (!in) throw std::runtime_error("cannot read pose pairs file " + pairs_path);
    std::vector<double> q(static_cast<size_t>(in.tellg()) / sizeof(double));
    in.seekg(0);
    in.read(reinterpret_cast<char *>(q.data()), static_cast<std::streamsize>(q.size() * sizeof(double)));
    Checker chk(pb);
    ob::StateSpacePtr space = make_space(pb);
    og::SimpleSetup ss(space);
    Counters count;
    ss.setStateValidityChecker([&chk](const ob::State *s) {
        const auto *p = s->as<ob::SE2StateSpace::StateType>();
        return chk.free(p->getX(), p->getY(), p->getYaw());
    });
    ob::SpaceInformationPtr si = ss.getSpaceInformation();
    ob::MotionValidatorPtr mv;
    if (pb.space == "dubins") mv = std::make_shared<DenseMotionValidator<DenseDubins, ob::DubinsStateSpace::DubinsPath>>(si, count);
    else mv = std::make_shared<DenseMotionValidator<DenseRS, ob::ReedsSheppStateSpace::ReedsSheppPath>>(si, count);
    si->setMotionValidator(mv);
    si->setup();
    ob::ScopedState<> a(space), b(space);
    std::vector<std::uint8_t> out(q.size() / 6);
    for (size_t k = 0; k < out.size(); ++k) {
        set_pose(a.get(), &q[6 * k]);
        set_pose(b.get(), &q[6 * k + 3]);
        out[k] = mv->checkMotion(a.get(), b.get());
    }
    std::ofstream(out_path, std::ios::binary).write(reinterpret_cast<const char *>(out.data()),
                                                   static_cast<std::streamsize>(out.size()));
    return 0;
}

int check(const Problem &pb, const std::string &poses_path, const std::string &out_path) {
    std::ifstream in(poses_path, std::ios::binary | std::ios::ate);
    if (!in) throw std::runtime_error("cannot read poses file " + poses_path);
    std::vector<double> poses(static_cast<size_t>(in.tellg()) / sizeof(double));
    in.seekg(0);
    in.read(reinterpret_cast<char *>(poses.data()), static_cast<std::streamsize>(poses.size() * sizeof(double)));
    Checker chk(pb);
    std::vector<std::uint8_t> out(poses.size() / 3);
    for (size_t k = 0; k < out.size(); ++k) out[k] = chk.free(poses[3 * k], poses[3 * k + 1], poses[3 * k + 2]);
    std::ofstream(out_path, std::ios::binary).write(reinterpret_cast<const char *>(out.data()),
                                                   static_cast<std::streamsize>(out.size()));
    return 0;
}

}  // namespace

int main(int argc, char **argv) {
    ompl::msg::setLogLevel(std::getenv("NHSIM_OMPL_LOG") ? ompl::msg::LOG_DEBUG : ompl::msg::LOG_NONE);
    try {
        std::string mode = argc > 1 ? argv[1] : "";
        if (mode == "check" && argc == 5) return check(read_problem(argv[2]), argv[3], argv[4]);
        if (mode == "motions" && argc == 5) return motions(read_problem(argv[2]), argv[3], argv[4]);
        if (mode == "serve" && argc == 4)
            return serve(read_problem(argv[2]), static_cast<unsigned>(std::stoul(argv[3])));
        if (mode == "plan" && argc == 7)
            return plan(read_problem(argv[2]), argv[3], std::stod(argv[4]), std::stoi(argv[5]),
                        static_cast<unsigned>(std::stoul(argv[6])));
        std::fprintf(stderr,
                     "usage: harness check PROBLEM POSES OUT | harness motions PROBLEM PAIRS OUT | harness plan PROBLEM PLANNER LIMIT TRIALS SEED | "
                     "harness serve PROBLEM SEED\n");
        return 2;
    } catch (const std::exception &exc) {
        std::fprintf(stderr, "harness: %s\n", exc.what());
        return 2;
    }
}
