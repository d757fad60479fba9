# Turns format-spec/bbc-format.md into the man page bbc(5). It knows the Markdown the
# spec uses and no more: headings, paragraphs, "- " and "1. " lists, fenced code and
# tables (both shown as they are, without filling), **bold** and *italic*; backticks
# are dropped.
#   awk -v version=0.1.0 -f md2man.awk bbc-format.md > bbc.5
function esc(s) {
  gsub(/\\/, "\\e", s)
  return s
}
function inline(s) {
  s = esc(s)
  while (match(s, /\*\*[^*]+\*\*/)) s = substr(s, 1, RSTART - 1) "\\fB" substr(s, RSTART + 2, RLENGTH - 4) "\\fR" substr(s, RSTART + RLENGTH)
  while (match(s, /\*[^* ][^*]*\*/)) s = substr(s, 1, RSTART - 1) "\\fI" substr(s, RSTART + 1, RLENGTH - 2) "\\fR" substr(s, RSTART + RLENGTH)
  gsub(/`/, "", s)
  if (s ~ /^[.']/) s = "\\&" s
  return s
}
function verbatim(s) {
  s = esc(s)
  if (s ~ /^[.']/) s = "\\&" s
  return s
}
# Ends a table (shown without filling) before anything else.
function end_table() { if (table) { print ".fi"; table = 0 } }
NR == 1 && /^# / {
  title = substr($0, 3)
  printf ".TH BBC 5 \"\" \"bbc %s\" \"bbc file formats\"\n", version
  print ".nh"; print ".ad l"; print ".SH NAME"
  print "bbc \\- " inline(title)
  print ".SH DESCRIPTION"
  next
}
code {
  if ($0 ~ /^```/) { print ".fi"; print ".RE"; code = 0; next }
  print verbatim($0)
  next
}
/^```/ { end_table(); print ".PP"; print ".RS 2"; print ".nf"; code = 1; next }
/^\|/ {
  if (!table) { print ".PP"; print ".nf"; table = 1 }
  if ($0 ~ /^\|[-|: ]+\|$/) next
  print verbatim($0)
  next
}
{ end_table() }
/^## / { print ".SH " inline(toupper(substr($0, 4))); next }
/^### / { print ".SS " inline(substr($0, 5)); next }
/^$/ { if (!blank) print ".PP"; blank = 1; next }
/^- / { print ".IP \\(bu 2"; print inline(substr($0, 3)); blank = 0; next }
/^[0-9]+\. / { n = index($0, " "); printf ".IP \"%s\" 4\n", substr($0, 1, n - 1); print inline(substr($0, n + 1)); blank = 0; next }
{ line = $0; sub(/^ +/, "", line); print inline(line); blank = 0 }
END {
  end_table()
  print ".SH SEE ALSO"
  print "\\fBbbc\\-precompute\\fR(1), \\fBbbc\\-render\\fR(1), \\fBbbc\\-inspect\\fR(1)"
}
