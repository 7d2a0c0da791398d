// D1 climbs half a metre a round until it is 10 m up, while D2 flies up
// to a spot beside its column: D2 comes near D1 resting between two
// climbs, so where D1 rests is recorded, and each climb starts from a
// rest the loop's guard, free to hold or not, leads to.
package ClimbBeside

var (
	D1 Quadcopter
	D2 Quadcopter
)

func PAR_Mission() {
	SEQ_Climber()
	SEQ_Visitor()
}

func SEQ_Climber() {
	D1.Arm()
	D1.Takeoff(2)
	RepeatUntil(D1.Z() >= 10, SEQ_Up)
	D1.Land()
}

func SEQ_Up() {
	D1.FlyByZ(0.5)
}

func SEQ_Visitor() {
	D2.Arm()
	D2.Takeoff(2)
	D2.FlyTo(0, -2.5, 6)
	D2.Land()
}
