# Turns a tool's --help text into its man page (section 1), so that the two cannot
# disagree: the build runs the tool with --help and pipes the text through this script.
#   awk -v tool=bbc-render -v version=0.1.0 -f help2man.awk < help.txt > bbc-render.1
# The text's own shape is kept: its first line "tool: what it does." is the NAME, the
# "usage:" lines the SYNOPSIS, a line ending in ':' at the margin a subsection, and
# every other line is kept as it is (no filling), so the rendered page shows the same
# lines as --help.
function esc(s) {
  gsub(/\\/, "\\e", s)
  gsub(/-/, "\\-", s)
  if (s ~ /^[.']/) s = "\\&" s
  return s
}
BEGIN { state = "name" }
NR == 1 {
  what = $0
  sub("^" tool ": *", "", what)
  sub(/\.$/, "", what)
  printf ".TH %s 1 \"\" \"bbc %s\" \"bbc manual\"\n", toupper(tool), version
  print ".nh"; print ".ad l"; print ".SH NAME"
  printf "%s \\- %s\n", esc(tool), esc(what)
  next
}
state == "name" && /^$/ { next }
state == "name" && /^[Uu]sage:/ {
  print ".SH SYNOPSIS"
  print ".nf"
  state = "synopsis"
}
state == "synopsis" {
  if ($0 ~ /^$/) {
    print ".fi"
    print ".SH DESCRIPTION"
    print ".nf"
    state = "body"
    next
  }
  line = $0
  sub(/^[Uu]sage: ?/, "", line)
  sub(/^ +/, "", line)
  if (length(line)) print esc(line)
  next
}
state == "name" { print ".SH DESCRIPTION"; print ".nf"; state = "body" }
state == "body" && /^[^ ].*:$/ {
  print ".fi"
  heading = $0
  sub(/:$/, "", heading)
  printf ".SS %s\n", esc(heading)
  print ".nf"
  next
}
state == "body" { print (length($0) ? esc($0) : "") }
END {
  if (state != "name") print ".fi"
  print ".SH SEE ALSO"
  print "\\fBbbc\\-precompute\\fR(1), \\fBbbc\\-render\\fR(1), \\fBbbc\\-inspect\\fR(1), \\fBbbc\\-scenegen\\fR(1), \\fBbbc\\fR(5)"
}
