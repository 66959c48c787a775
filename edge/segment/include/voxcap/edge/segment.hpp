// GVD segmentation of a silhouette in the initialization pose (the method's section 5, "GVD
// segmentation" in shared/paper-notes.md): the five terminal regions head, hands and feet, and a 2D
// position for each, from one camera's binary mask. Run at initialization and on re-acquisition,
// not per frame.
//
// The algorithm (src/segment.cpp has the details and the limits):
//   1. The mask's largest 8-connected component, holes filled, smoothed by an opening and a closing
//      of radius Options::smooth_ratio x its height (ragged borders, speckles); too small, touching
//      the image border, or larger than Options::max_width x max_height: ok = false with the reason.
//   2. Distance transform with the nearest background pixel of every silhouette pixel (clearance).
//   3. The GVD: silhouette pixels whose 4-neighbour's nearest background pixel lies far from their
//      own (more than gvd_ratio x the clearance: two boundary points at an angle, which prunes the
//      spurs of a ragged border), one pixel wide.
//   4. Critical points: GVD pixels whose clearance is the smallest along the GVD within
//      min_ratio x clearance, that the GVD leaves on two sides, and from which the clearance rises
//      by rise_ratio within window_ratio x clearance on at least one (a constriction).
//   5. Cuts: the line through the two boundary points nearest the critical point; the silhouette
//      minus the cuts gives the regions, the cuts their adjacency graph; tiny regions are merged.
//   6. Terminals (the initialization pose: arms spread, legs together). The head is the leaf of the
//      graph in the top head_band_ratio of the silhouette nearest the body's axis (the median column
//      over the hips), within 15 % of the height of it, reaching the top 8 % and holding a disc of
//      head_disc_ratio x height; without such a leaf (a hand seen above the shoulder joins the head, a
//      mask that lost the chest leaves no neck) the largest disc in the top head_top_ratio near the
//      axis where the silhouette is head-wide. The hands are the two leaves of the upper half farthest
//      from the axis, or, for an arm without a constriction (even width, a hand seen edge-on, an arm
//      foreshortened by a camera looking along it), the silhouette's extremities (local maxima of the
//      geodesic distance from the head) in the upper half; either only if hand-like: beside the head
//      and beyond its outline, at the end of an arm-thin part at least half a hand long and somewhere
//      as thick as a forearm (not a spur of a ragged head, not a sliver of a broken mask). The feet
//      are not leaves (from the front an ankle is no narrower than its foot, and legs together
//      touch): they are the pieces of the silhouette's lowest foot_band_ratio; one piece for both is
//      split into its two runs at ankle height, or about the body's axis.
//      One hand found (the other hidden by a camera looking along the arms): it is labelled by its
//      side of the head and the other is not_visible (terminal -1); a silhouette too short for its
//      head (head disc above max_head_ratio x height: the mask lost the legs) has its feet
//      not_visible. No hand, or one without legs: ok = false and why ("5 terminals expected, ...").
//
// Left and right are decided per image, by the image side, as if the camera faced the performer:
// left_hand is the hand whose point is on the image's right (larger x), right_hand the one on the
// left; the same for the feet. For a camera behind the performer that is the performer's other
// side: the host agrees the labels across views by triangulation, this library does not guess.
//
// The feature positions are those of hw/sim's truth (truth/features.csv): the head's centre (the
// centre of the largest disc inside the head region); the wrist wrist_shift x clearance beyond the
// hand's cut into the arm, or, when the hand's leaf reaches far beyond a hand (a cut at the elbow)
// or there is none, hand_ratio x height back from the hand's extremity along the silhouette, on the
// GVD; the ankle ankle_ratio x height above the foot's lowest pixel, in the middle of its run.
// Measured on hw/sim (bin/edge_segment_survey; README.md): on the initialization frames of every
// appearance preset, both rooms, rigs of 4, 6 and 8 cameras, every terminal of every camera is
// labelled right on the true silhouettes (2D error median 2.3 px, p95 14 px: foreshortened arms,
// one foot behind the other) and on 426 of 432 camera frames of the edge's masks.
//
// Not thread-hostile: segment() and draw() keep no state; call them from any thread.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vc::segment {

// Every threshold is in pixels or is a ratio of the silhouette's size (its bounding box height),
// so one set of defaults works from 320x240 to 1456x1088.
struct Options {
  int max_width = 4096;  // larger masks are refused (bounds the work)
  int max_height = 4096;
  int min_area_px = 300;            // a smaller silhouette is refused
  int min_height_px = 40;           // ... and one shorter than this
  double smooth_ratio = 0.006;      // opening/closing radius: this x height (rounded; 0: none)
  double gvd_ratio = 1.2;           // GVD: the two boundary points are more than this x clearance apart
  double min_ratio = 1.0;           // critical points: minimum along the GVD within this x clearance,
  double window_ratio = 3.0;        // ... the clearance rises by rise_ratio within this x clearance
  double min_window_px = 4.0;       // ... (both windows at least this many pixels)
  double rise_ratio = 0.15;         // ... on at least one side (a wrist: even width up to the elbow)
  double wrist_shift = 1.0;         // the wrist: this x the cut's clearance beyond it, into the arm
  double min_region_ratio = 0.002;  // regions smaller than this x the silhouette's area are merged
  double foot_band_ratio = 0.15;    // feet: leaves reaching into the lowest fraction of the height
  double head_band_ratio = 0.35;    // head: a leaf whose centre is in the highest fraction
  double head_top_ratio = 0.12;     // ... or, without such a leaf, the largest disc in this top fraction
  double head_disc_ratio = 0.03;    // ... either holding a disc of at least this x height (a head ~0.055)
  double max_head_ratio = 0.085;    // a head's disc larger than this x height: the legs are lost
  double hand_ratio = 0.1;          // wrist to finger tips: this x height (when no cut is near)
  double ankle_ratio = 0.08;        // ankle: this x height above the foot's lowest pixel

  // True when usable; otherwise *why (if given) names the first bad field.
  bool valid(std::string* why) const;
};

struct Cut {
  cv::Point critical;   // the critical point on the GVD
  cv::Point2f a, b;     // the two boundary points nearest it (on the silhouette's outline)
  float clearance = 0;  // distance from the critical point to the background (px)
};

struct Region {
  int id = -1;
  int area = 0;  // pixels
  cv::Rect box;
  cv::Point2f centroid;
  std::vector<int> neighbours;  // ids of the regions across a cut (sorted, unique)
};

// The features in proto's vc_feature_id order (voxcap/proto.h).
enum Feature : int { kHead = 0, kLeftHand = 1, kRightHand = 2, kLeftFoot = 3, kRightFoot = 4 };
inline constexpr int kFeatures = 5;
const char* feature_name(int f);  // "head", "left_hand", ...

struct Segmentation {
  bool ok = false;
  std::string why;                  // why not, e.g. "5 terminals expected, found 3"; "" when ok
  cv::Mat1f distance;               // distance to the background (px), the mask's size; 0 outside
  cv::Mat1b gvd;                    // the GVD / medial axis (255)
  std::vector<cv::Point> critical;  // critical points (local clearance minima along the GVD)
  std::vector<Cut> cuts;            // one per critical point that separates two regions
  cv::Mat1i labels;                 // region id per pixel, -1 background
  std::vector<Region> regions;      // regions[i].id == i, with the adjacency graph
  // Region id per feature; -1: not labelled, i.e. not_visible in this view (a hand hidden behind the
  // body, feet of legs the mask lost) while ok, and its point is meaningless.
  std::array<int, kFeatures> terminal{{-1, -1, -1, -1, -1}};
  std::array<cv::Point2f, kFeatures> point{};  // the feature's 2D position (px)
};

// Segments one camera's mask (0 = background, anything else = silhouette). Never throws for a bad
// mask: a result with ok == false and the reason (the intermediate images are filled as far as the
// work went). Throws std::invalid_argument for invalid options only.
Segmentation segment(const cv::Mat1b& mask, const Options& opt = {});

// The debug picture: bgr (CV_8UC3 of the mask's size, or empty: a grey silhouette) with the regions
// tinted, the GVD, the critical points, the cuts and the five labelled points. *out is replaced.
void draw(const Segmentation& s, const cv::Mat& bgr, cv::Mat* out);

}  // namespace vc::segment
