"""The gap-seeking policy ("gap"): the gaps of the target lane and the speed that takes
the SV into one (geometry), the decision each step while it keeps its lane (decision),
and the policy that flies the paper's manoeuvre into the gap once it is reached (policy)."""
