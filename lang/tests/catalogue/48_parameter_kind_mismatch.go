// A drone parameter given a number, a number parameter given a drone, and
// a whole-number parameter given a fraction.
package ParamKinds

var Drone1 Quadcopter

func INIT() {
	SEQ_Square(2, Drone1)
	SEQ_Laps(Drone1, 1.5)
}

func SEQ_Square(d Quadcopter, side float64) {
	d.FlyByX(side)
}

func SEQ_Laps(d Quadcopter, n int) {
	d.FlyByX(n)
}
