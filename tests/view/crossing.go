// A planted collision for `eamos view`'s tests: Alpha and Bravo swap
// sides at the same height at the same time, and Alpha then flies on out
// of the fence (tests/view/crossing_fleet.toml).
package Crossing

var Alpha Quadcopter
var Bravo Quadcopter

func SEQ_Crossing() {
	PAR_Up()
	PAR_Swap()
	Alpha.FlyByX(30)
	PAR_Down()
}

func PAR_Up() {
	SEQ_AlphaUp()
	SEQ_BravoUp()
}

func SEQ_AlphaUp() {
	Alpha.Arm()
	Alpha.Takeoff(5)
}

func SEQ_BravoUp() {
	Bravo.Arm()
	Bravo.Takeoff(5)
}

func PAR_Swap() {
	Alpha.FlyByY(6)
	Bravo.FlyByY(-6)
}

func PAR_Down() {
	Alpha.Land()
	Bravo.Land()
}
