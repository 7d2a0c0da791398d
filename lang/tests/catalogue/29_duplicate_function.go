// The same function declared twice.
package DuplicateFunc

var Drone1 Quadcopter

func INIT() {
	SEQ_Fly()
}

func SEQ_Fly() {
	Drone1.FlyByX(1)
}

func SEQ_Fly() {
	Drone1.FlyByY(1)
}
