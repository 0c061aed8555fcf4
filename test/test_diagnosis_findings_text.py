"""What the findings' note says of the effect that explains them (findings.explain_findings)."""
from types import SimpleNamespace

from tca_ros.diagnosis import findings
from tca_ros.diagnosis.findings import explain_findings, FindingTest
from tca_ros.diagnosis.joint import JointFit


def _explained(monkeypatch, admitted):
    # seed 9131 of the confusion benchmark at two loads (a power loss, cst plant at 5 Hz):
    # the heat loss moved +2.1 spreads, and an ambient offset (G90) explained it best,
    # sized within the room the description states
    fit = JointFit(name='ambient_offset', values={}, n_params=1, sims=['a'], criterion=-3.7,
                   explained=True, pinned=[], admitted=admitted)
    test = FindingTest(fit=fit, fall=0.7, deviance=-3.7, returned=True, passes=True)
    monkeypatch.setattr(findings, 'finding_tests', lambda *args: [test])
    cal = SimpleNamespace(findings=lambda implausible=False: [
        ('heat_loss', 2.06, ('power_loss', 'ambient_offset'))])
    taken, notes = explain_findings(None, [], [], cal, [])
    assert taken is test
    return notes[0]


def test_an_effect_the_description_admits_explains_the_findings_but_is_not_named(monkeypatch):
    note = _explained(monkeypatch, admitted=('ambient_offset',))
    assert note.startswith('findings heat_loss (+2.1 spreads): ambient_offset, calibrated')
    assert 'the muscle as described: not named' in note and ': named' not in note
    # sized beyond what the description states: named
    note = _explained(monkeypatch, admitted=())
    assert ': named (docs/diagnosis_method.md, "Findings")' in note
    assert 'muscle as described' not in note
