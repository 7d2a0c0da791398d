// Two parameters of one function with the same name.
package DuplicateParam

var Drone1 Quadcopter

func INIT() {
	SEQ_Move(Drone1, 1, 2)
}

func SEQ_Move(d Quadcopter, x float64, x float64) {
	d.FlyByX(x)
}
