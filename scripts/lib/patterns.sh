# Sourced by scripts/stress.sh and scripts/models.sh: which names the PATTERN arguments select.
# matches NAME: true when PATTERNS (an array) is empty, or when one of its patterns matches NAME,
# as a shell glob if it holds *, ? or [, else as a substring.
matches() {
    local name=$1 p
    [ ${#PATTERNS[@]} -eq 0 ] && return 0
    for p in "${PATTERNS[@]}"; do
        case $p in *[\*\?\[]*) [[ $name == $p ]] && return 0 ;; *) [[ $name == *"$p"* ]] && return 0 ;; esac
    done
    return 1
}
