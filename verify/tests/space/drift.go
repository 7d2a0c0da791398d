// Each round of the loop takes D1 five metres further north.
package Drift

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(5)
	RepeatWhile(D1.Battery() > 30, SEQ_Step)
	D1.Land()
}

func SEQ_Step() {
	D1.FlyByX(5)
}
