#!/bin/sh
# Tetrahedra the quality refinement leaves away from small input angles
# (issue 12): CGAL's pinion, pinion_small, joint, pipe and rotor_small, from Debian's
# libcgal-dev at test time (tests/cad-lib.sh; skipped, never passed,
# without the package).
#
# Nearly all the tetrahedra these parts left "given up elsewhere" were
# given up because the subsegment split their circumcentre asked for had
# no cavity: the constrained cavity of a point on the subsegment folded
# behind faces no flip mends, and could not be shrunk to a star. The
# passes after the run (shrink_passes, refine_run.c) now queue the
# tetrahedra the run gave up above the radius-edge bound away from small
# input angles, and a subsegment split one of those asks for whose cavity
# folds takes the tetrahedra around the subsegment
# instead (edge_star_cavity, refine_cdt.c), as a split that a face no flip
# mends asks for does. Before: pinion 247 left above ratio 2 (TetGen 3),
# pinion_small 164 (TetGen 7), joint 64 (TetGen 5), 44 of joint's given up
# elsewhere; after: 0, 23, 8 and none (the splits on segments at a small
# input angle keep their old rule).
#
# The summary also says which of the tetrahedra given up for want of a
# usable circumcentre are flat ("degenerate": no circumcentre in conflict
# with them, or flat on a facet) and which had one whose cavity could not
# be made ("hidden"); it had one label for both. joint's are hidden ones.
#
# The passes stop once they have added more than a quarter of the
# vertices the mesh had before them (REF_SHRINK_GROWTH): on pipe, a thin
# tube, the faces no flip mends along the wall kept asking for splits,
# and the passes made 9,492 tetrahedra (1.55 times TetGen's 6,137) to
# leave 815 above ratio 2; they now stop after the first, at 8,569
# tetrahedra and 728 left.
#
# A pass also does not start once the last one left no fewer tetrahedra
# to retry than it started with: on rotor_small each of the four passes
# left more (967, 1,420, 1,948, 2,408 queued), and they took 2.4 of the
# run's 2.8 seconds to end at 7,350 above ratio 2 in 46,975 tetrahedra;
# it now stops after the first, at 5,446 in 42,339.
#
# pipe has no small input angle at all, yet the refinement left 728: its
# tube walls are strips 1 long and 0.027 or 0.049 wide, whose long
# segments every mesh with radius-edge below 2 cuts into pieces shorter
# than 8 times the strip's width (plc/plc_split.h); cut one at a time
# where bad tetrahedra asked, each split point made the long segments
# across the wall no longer strongly Delaunay, and the flips left faces
# no flip mends, behind which cavities folded. Cut before the Delaunay
# tetrahedralization of the input, below 6 times the width (pdr mesh
# --presplit, by default on inputs without small angles), it leaves none
# (TetGen 2) in 6,970 tetrahedra; the bound below (TetGen's count) fails
# the build before.
#
# For each part: exit 0 within the time limit, at most 1.5 times
# TetGen's tetrahedra, pdr check --plc IN --max-ratio 2 finds nothing but
# what the summary reports, and at most the given count left above ratio
# 2 (room for small changes elsewhere; far below the counts before).
# pinion_small's bound went from 40 to 60 when near-planar facets became
# 1e-5 by default (plc/fm.h): it leaves 41 there (23 at 1e-6; its
# renumberings 19-104 against 25-88), the one part of this test that
# the larger tolerance makes worse.
set -u
fail() { echo "FAIL: $*"; exit 1; }
. "$top_srcdir/tests/cad-lib.sh"
tmp=$(pwd)/mesh-cad-leftover.$$
mkdir -p "$tmp" || exit 99
trap 'rm -rf "$tmp"' EXIT
cad_extract "$tmp" pinion pinion_small joint pipe rotor_small
data=$tmp/data/meshes

# name  seconds  TetGen's tetrahedra  bound (1.5 times)  most left above ratio 2
cad_bounded_rows <<EOF
pinion 30 15407 23110 40
pinion_small 30 15307 22960 60
joint 30 7742 11613 24
pipe 30 6137 9205 2
rotor_small 30 40776 61164 5800
EOF

# pipe's long segments were cut first, and the summary says so.
grep -q '^input preparation: 80 segments along thin facets cut' "$tmp/pipe.out" ||
    fail "pipe: no line for the segments cut along thin facets"

# The labelled kinds of $1's "left above the bound" line into $kinds
# ("total angle refused degenerate hidden other") and $line, checked to
# add up.
kinds_of() {
    line=$(grep '^left above the bound:' "$tmp/$1.out")
    kinds=$(printf '%s\n' "$line" | sed -n 's/^left above the bound: \([0-9]*\) tetrahedra with radius-edge >= 2 (\([0-9]*\) next to small input angles, \([0-9]*\) given up elsewhere (their splits refused), \([0-9]*\) degenerate (flat: no usable circumcentre), \([0-9]*\) hidden (circumcentre.s cavity not made), \([0-9]*\) other).*/\1 \2 \3 \4 \5 \6/p')
    [ -n "$kinds" ] || fail "$1: no labelled kinds in '$line'"
    set -- $kinds
    [ "$1" -eq $(($2 + $3 + $4 + $5 + $6)) ] || fail "the kinds do not add up: $line"
}

# joint's given up elsewhere are gone, and what it leaves for want of a
# usable circumcentre is hidden, not degenerate (no flat one).
kinds_of joint
set -- $kinds
[ "$3" -le 4 ] || fail "joint: $3 given up elsewhere (44 before the leftover passes)"
[ "$4" -eq 0 ] && [ "$5" -gt 0 ] || fail "joint: expected hidden ones and no degenerate: $line"
echo "joint: $line"

# rotor_small leaves tetrahedra flat on a facet once their facet's splits
# are spent (refine_run.c, flat_spent): degenerate, not hidden (all 14
# were counted hidden before; 11 degenerate and 3 hidden since).
kinds_of rotor_small
set -- $kinds
[ "$4" -gt 0 ] || fail "rotor_small: expected flat ones counted degenerate: $line"
echo "rotor_small: $line"
echo "ok"
