# tests/cad-lib.sh -- sourced by the tests that mesh other people's CAD
# parts (tests/mesh-cad-*.sh, tests/mesh-parallel-cad.sh): the parts
# come from Debian's libcgal-dev at test time, and every mesh gets the
# same checks of what pdr check finds against what the summary reports.
# The caller defines fail() and sets PDR. The functions set the globals
# they name ($nt, $nd, $left) and others prefixed cad_ or used only here.

# cad_extract TMP NAME...: extracts data/meshes/NAME.off of CGAL's example
# data into TMP, or exits 77 (skip) without the package.
cad_extract() {
    cad_tmp=$1
    shift
    cgal=${CGAL_DATA:-/usr/share/doc/libcgal-dev/data.tar.gz}
    [ -f "$cgal" ] || { echo "SKIP: no $cgal (apt-get install libcgal-dev)"; exit 77; }
    for cad_n in "$@"; do
        set -- "$@" "data/meshes/$cad_n.off"
        shift
    done
    tar -xzf "$cgal" -C "$cad_tmp" "$@" || fail "cannot extract the parts from $cgal"
}

# cad_tets LABEL OUT: the tetrahedra of summary OUT (more than 0) in $nt.
cad_tets() {
    nt=$(sed -n 's/^mesh: [0-9]* vertices, \([0-9]*\) tetrahedra.*/\1/p' "$2")
    [ -n "$nt" ] && [ "$nt" -gt 0 ] || fail "$1: '$nt' tetrahedra"
}

# cad_check LABEL IN MESH OUT [pdr check options]: pdr check --plc IN
# --max-ratio 2 of MESH (summary OUT) finds no defect but tetrahedra above
# ratio 2 and faces not locally Delaunay, and exactly as many of those
# faces as the summary says were left ($nd). The report is in MESH.chk.
cad_check() {
    cad_label=$1 cad_in=$2 cad_mesh=$3 cad_out=$4
    shift 4
    "$PDR" check --plc "$cad_in" "$@" --max-ratio 2 "$cad_mesh" >"$cad_mesh.chk" 2>&1
    other=$(grep -- '<-- DEFECT' "$cad_mesh.chk" |
        grep -v -e '^tetrahedra with radius-edge ratio' -e '^ *faces not locally Delaunay')
    [ -z "$other" ] || { cat "$cad_mesh.chk"; fail "$cad_label: $other"; }
    nd=$(sed -n 's/^ *faces not locally Delaunay *\([0-9]*\).*/\1/p' "$cad_mesh.chk")
    said=$(sed -n 's/^left not locally Delaunay: \([0-9]*\) faces.*/\1/p' "$cad_out")
    [ -n "$nd" ] || fail "$cad_label: no Delaunay count from pdr check"
    [ "$nd" -eq "${said:-0}" ] ||
        fail "$cad_label: pdr check finds $nd faces not locally Delaunay, the summary '${said:-0}'"
}

# cad_check_cover LABEL MESH OUT: after cad_check, the report says every
# facet is covered, and it finds no more tetrahedra above ratio 2 than
# the summary reports left ($left).
cad_check_cover() {
    grep -q '^ *facets not covered (area differs) *0$' "$2.chk" ||
        fail "$1: no facet coverage line from pdr check"
    bad=$(sed -n 's/^tetrahedra with radius-edge ratio >= 2: \([0-9]*\).*/\1/p' "$2.chk")
    left=$(sed -n 's/^left above the bound: \([0-9]*\) tetrahedra with radius-edge.*/\1/p' "$3")
    [ -n "$bad" ] && [ -n "$left" ] || fail "$1: no ratio counts ('$bad', '$left')"
    [ "$bad" -le "$left" ] || fail "$1: pdr check finds $bad above ratio 2, the summary $left"
}

# cad_bounded NAME SECS TETGEN BOUND MAXLEFT [NOTE]: pdr mesh of
# $data/NAME.off with the default options, into $tmp/NAME, exits 0 within
# SECS seconds with at most BOUND tetrahedra (TETGEN: TetGen's, for the
# messages), passes cad_check and cad_check_cover, and leaves at most
# MAXLEFT above ratio 2. NOTE goes into the messages in parentheses.
cad_bounded() {
    cad_name=$1 cad_secs=$2 cad_tetgen=$3 cad_bound=$4 cad_maxleft=$5
    cad_note=${6:+ ($6)}
    cad_bin=$data/$cad_name.off
    cad_bmesh=$tmp/$cad_name
    timeout "$cad_secs" "$PDR" mesh -o "$cad_bmesh" "$cad_bin" >"$cad_bmesh.out" 2>&1
    rc=$?
    [ "$rc" -eq 0 ] || { cat "$cad_bmesh.out"; fail "$cad_name: pdr mesh exited $rc"; }
    cad_tets "$cad_name" "$cad_bmesh.out"
    [ "$nt" -le "$cad_bound" ] ||
        fail "$cad_name: $nt tetrahedra, more than $cad_bound (TetGen $cad_tetgen)"
    cad_check "$cad_name" "$cad_bin" "$cad_bmesh" "$cad_bmesh.out"
    cad_check_cover "$cad_name" "$cad_bmesh" "$cad_bmesh.out"
    [ "$left" -le "$cad_maxleft" ] ||
        fail "$cad_name: $left tetrahedra left above ratio 2, more than $cad_maxleft$cad_note"
    echo "$cad_name: $nt tetrahedra (TetGen $cad_tetgen), $nd faces not locally Delaunay," \
        "$left left above ratio 2$cad_note"
}

# cad_bounded_rows: cad_bounded for each line "NAME SECS TETGEN BOUND
# MAXLEFT" of standard input.
cad_bounded_rows() {
    while read -r name secs tetgen bound maxleft; do
        cad_bounded "$name" "$secs" "$tetgen" "$bound" "$maxleft"
    done
}
