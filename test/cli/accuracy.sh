#!/usr/bin/env bash
# accuracy.sh - `--accuracy default|high|pixels` (issue 39) on `ff`, and
# `validate --catalog` refusing a bad --accuracy.
#
# Two unit squares 0.05 apart, black, at the default patch size (17 × 17):
# Howell C-11 gives F = 0.90785314.  Measured: pixels 0.87331956 (-3.8 %:
# near the gap a patch's centre is what is wrong), default 0.90557821
# (-2.5e-3), high 0.90785310 (-4.8e-8).  Bounds: pixels more than 3 % low
# (it is the unrepaired engine), default within 0.6 %, high within 1e-5.
set -u
source "$(dirname "$0")/lib.bash"

cat > "$dir/near.rad" <<'R'
bands 1
material black reflectance 0
polygon A black
  0 0 0   1 0 0   1 1 0   0 1 0
end
polygon B black
  0 0 0.05   0 1 0.05   1 1 0.05   1 0 0.05
end
R
# rel VALUE REFERENCE: VALUE / REFERENCE - 1
rel() { awk -v v="$1" -v r="$2" 'BEGIN { printf "%.9f", v / r - 1 }'; }
within() { awk -v d="$1" -v lo="$2" -v hi="$3" 'BEGIN { exit !(d >= lo && d <= hi) }'; }
for a in pixels default high; do
    f=$("$BIN" ff "$dir/near.rad" --from A --to B --accuracy "$a" 2> "$dir/err" | awk '/^F\(A -> B\)/ { print $5 }')
    d=$(rel "${f:-0}" 0.90785314)
    case $a in
        pixels) lo=-1; hi=-0.03 ;;
        default) lo=-0.006; hi=0.006 ;;
        high) lo=-1e-5; hi=1e-5 ;;
    esac
    if [ -n "$f" ] && within "$d" "$lo" "$hi"; then ok "ff --accuracy $a: F = $f ($d)"; else bad "ff --accuracy $a: F = '$f' ($d) not in [$lo, $hi]: $(cat "$dir/err")"; fi
done

# Plates at right angles sharing an edge of 1, widths 0.2 (A) and 3 (B),
# black: Howell C-14 gives F_AB = 0.39918502, F_BA = 0.026612335.  ff's
# defaults take F_AB as the area average it is (HC_WEAK_SURFACE).  Measured:
# default 0.40057508 (+3.5e-3) and 0.02653210 (-3.0e-3); pixels 0.40509595
# (+1.5 %, as the defaults were before).  Bounds: default within 0.9 % both
# ways, pixels more than 1.2 % high.
cat > "$dir/plates.rad" <<'R'
bands 1
material black reflectance 0
polygon A black
  0 0 0   1 0 0   1 0.2 0   0 0.2 0
end
polygon B black
  0 0 0   0 0 3   1 0 3   1 0 0
end
R
for a in default pixels; do
    "$BIN" ff "$dir/plates.rad" --from A --to B --accuracy "$a" > "$dir/out" 2> "$dir/err"
    fab=$(awk '/^F\(A -> B\)/ { print $5 }' "$dir/out")
    fba=$(awk '/^F\(B -> A\)/ { print $5 }' "$dir/out")
    dab=$(rel "${fab:-0}" 0.39918502)
    dba=$(rel "${fba:-0}" 0.026612335)
    if [ "$a" = default ]; then
        within "$dab" -0.009 0.009 && within "$dba" -0.009 0.009
    else
        within "$dab" 0.012 1
    fi
    if [ $? -eq 0 ] && [ -n "$fab" ]; then ok "ff plates --accuracy $a: F_AB $fab ($dab), F_BA $fba ($dba)"; else bad "ff plates --accuracy $a: F_AB '$fab' ($dab), F_BA '$fba' ($dba): $(cat "$dir/err")"; fi
done

for cmd in "ff $dir/near.rad --from A --to B --accuracy best" "validate --catalog --accuracy best"; do
    # shellcheck disable=SC2086
    "$BIN" $cmd > "$dir/out" 2> "$dir/err"
    rc=$?
    if [ $rc -eq 2 ] && [ "$(wc -l < "$dir/err")" -eq 1 ] && grep -q "^radiosity: error: .*--accuracy 'best'" "$dir/err"; then
        ok "$cmd: exit 2, one line"
    else
        bad "$cmd: exit $rc: $(cat "$dir/err")"
    fi
done
echo "accuracy.sh: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
