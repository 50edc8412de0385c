"""The theory of linear complementarity systems that pelcs checks before and beside a run:
passivity (:mod:`.passivity`), the cheap screen of it before a run (:mod:`.screening`),
well-posedness, consistent states and state jumps (:mod:`.wellposed`), the GDCM conditions
(:mod:`.gdcm`), and when a θ step's next state is unique whatever its multipliers
(:mod:`.step_uniqueness`)."""
