"""The ``nash`` and ``stackelberg`` controllers: the paper's decision process (Algorithm 1) in the
closed loop, from the relations and the ETM to the pair games, the solo plans and the anytime step
(see ``controller``)."""
